"""A zone of different stiffness past a crush depth."""

from __future__ import annotations

from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp

from sim.mechanisms.base import Mechanism
from sim.smooth import smooth_relu


class StiffnessZone(Mechanism):
    """Past the crush depth ``depth`` the structure's stiffness becomes ``k_zone``.

    F = F_before + (k_zone - k_compression) * A * R(d - depth), R a ramp max(0, .)
    smoothed over ``width``: the force stays continuous and its slope changes from
    k_compression*A to k_zone*A (stiffer when the engine block meets the barrier, softer
    when a member buckles).

    Attributes
    ----------
    depth : m, crush depth where the zone starts.
    k_zone : N/m^3, stiffness per unit contact area beyond ``depth``.
    width : m, smoothing width of the ramp (static).
    """

    effect = "stiffness_zone"
    explanation = (
        "The front structure changes stiffness past a crush depth, as when the engine block "
        "or a cross member reaches the barrier and the force rises faster from there on."
    )
    units = {"depth": "m", "k_zone": "N/m^3"}

    softer_explanation: ClassVar[str] = (
        "The front structure gets softer past a crush depth, as when a crash box or a "
        "longitudinal member has buckled, so the force rises more slowly from there on."
    )

    depth: jnp.ndarray
    k_zone: jnp.ndarray
    width: float = eqx.field(static=True, default=0.002)

    def explain(self, params) -> str:
        """The stiffening sentence, or the softening one when k_zone < k_compression."""
        return self.softer_explanation if float(self.k_zone) < float(params.k_compression) else self.explanation

    def loading_force(self, force, crush, crush_rate, params, vehicle):
        extra = (self.k_zone - params.k_compression) * vehicle.contact_area
        return force + extra * smooth_relu(crush - self.depth, self.width)
