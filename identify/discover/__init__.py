"""discover: the physics the base model left out, found, named or called unexplained.

    base FitResult ──fitting.residuals──▶ a misfit beyond noise?
        ──loop.discover──▶ each candidate of ``candidates.REGISTRY`` refitted (one compiled
                           superset model), scored with one BIC per round, checked against the
                           channels the recording measures directly (its evidence check),
                           held-out prediction before acceptance
        ──missing_force──▶ the generic missing force: what a named candidate must match, and
                           what is reported as "unexplained" (window and shape) when none does
        ──plots──▶ residuals before and after, force-deflection

- ``candidates``: one module per mechanism (equation, fit settings, starting rules, evidence
  check), found through ``candidates.REGISTRY``.
- ``loop``: ``discover(measurement, vehicle, base_fit) -> DiscoveryResult``; ``fit_base``.
- ``missing_force``: the data-driven fall-back estimate of a missing force over time.
- ``plots``: the discovery's figures (PNG).
"""
