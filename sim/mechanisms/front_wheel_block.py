"""Front wheels blocked by the crushed structure."""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp

from sim.mechanisms.base import Mechanism
from sim.smooth import smooth_step


class FrontWheelBlock(Mechanism):
    """The front wheels stop turning while the crush depth d exceeds ``depth``.

    blocked = max(blocked, S((d - depth) / width)), S the logistic step; a blocked wheel
    slides with the slip (and, at low speed, adhesive) friction coefficient instead of
    rolling. When the crush recovers below ``depth`` in the restitution phase the wheels
    turn again. The natural ``depth`` is where the crush reaches the tyre: front overhang
    minus wheel radius (:meth:`at_tyre`).

    Attributes
    ----------
    depth : m, crush depth at which the wheels block.
    width : m, smoothing width of the step (static).
    """

    effect = "front_wheel_block"
    explanation = (
        "The crushed front structure reaches the front tyres and jams them, so the front "
        "wheels stop turning and slide while the crush is deeper than the blocking depth."
    )
    units = {"depth": "m"}

    depth: jnp.ndarray
    width: float = eqx.field(static=True, default=0.002)

    @classmethod
    def at_tyre(cls, vehicle) -> "FrontWheelBlock":
        """Blocking when the crush reaches the tyre: depth = front_overhang - wheel_radius."""
        return cls(depth=jnp.asarray(vehicle.front_overhang - vehicle.wheel_radius, dtype=float))

    def front_blocked(self, blocked, crush, vehicle):
        return jnp.maximum(blocked, smooth_step(crush - self.depth, self.width))
