"""Progressive (non-linear) force-deflection."""

from __future__ import annotations

import jax.numpy as jnp

from sim.mechanisms.base import Mechanism


class ProgressiveStiffness(Mechanism):
    """The stiffness grows linearly with crush: F = F_before * (1 + progression * d).

    progression = 0 is the linear law; > 0 progressive (force rises faster than the
    crush), < 0 degressive (progression * d must stay > -1 over the crush reached).

    Attributes
    ----------
    progression : 1/m.
    """

    effect = "progressive_stiffness"
    explanation = (
        "The front structure stiffens gradually as it crushes (more material is compacted), "
        "so the force rises faster than in proportion to the crush depth."
    )
    units = {"progression": "1/m"}

    progression: jnp.ndarray

    def loading_force(self, force, crush, crush_rate, params, vehicle):
        return force * (1.0 + self.progression * crush)
