"""synth: the reference world, synthetic crash tests the fit does not share.

An independent crash simulator (NumPy/SciPy, ``solve_ivp`` with events; richer than
``sim``: engine on mounts, unsprung wheels with tyres, a non-linear unloading law) and a
renderer of randomized crash footage, so that the whole chain ``film -> video -> identify``
is measured on data our own model did not make. Never imports ``sim``, ``identify`` or
``video``.
"""
