"""Rate (strain-rate) dependence of the crush force."""

from __future__ import annotations

import jax.numpy as jnp

from sim.mechanisms.base import Mechanism


class RateDependence(Mechanism):
    """The loading force grows with the crush rate: F = F_before * (1 + rate_coefficient * v_c),
    v_c = max(0, crush rate) in m/s.

    Steel's flow stress rises with strain rate, so a structure crushed fast resists more
    than when crushed slowly; the extra force fades as the car slows down.

    Attributes
    ----------
    rate_coefficient : s/m (0.01 s/m adds 15 % at 15 m/s).
    """

    effect = "rate_dependence"
    explanation = (
        "The structure resists more when it is crushed fast (strain-rate hardening of steel), "
        "so the force is highest early in the impact and falls as the car slows."
    )
    units = {"rate_coefficient": "s/m"}

    rate_coefficient: jnp.ndarray

    def loading_force(self, force, crush, crush_rate, params, vehicle):
        return force * (1.0 + self.rate_coefficient * jnp.maximum(crush_rate, 0.0))
