"""identify: crash-test recordings in, collision-model parameters out.

The glue between ``video`` (film -> measured motion) and ``sim`` (the collision model):
fitting, discovery of missing physics, results and the command line (``identify.cli``).
"""
