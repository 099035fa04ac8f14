"""The base class of optional mechanisms: physics the base model leaves out.

A mechanism is a small pytree (its parameters are JAX arrays, so a fit can move them) that
overrides one or more hooks; the defaults change nothing. The simulation calls every
mechanism of ``Params.mechanisms`` in order:

- ``loading_force(force, crush, crush_rate, params, vehicle) -> force``: the barrier force
  (N) on the loading curve, given the force of the curve so far, crush (m) and crush rate
  (m/s). Unloading follows from the energy absorbed on this curve (see ``sim.contact``).
- ``front_blocked(blocked, crush, vehicle) -> blocked``: the fraction (0..1) by which the
  front wheels are blocked, given the fraction so far.

A mechanism with ``has_body`` is a second body moving along x (the engine): it takes
``detached_mass()`` (kg) out of the cabin's x inertia and carries its own state through the
integration: ``body_init(speed) -> state``; ``body_forces(state, q, v) -> (force on the
cabin along x (N), force on the barrier (N), aux)`` at the step's start; ``body_advance(state,
(cabin force, barrier force), aux, q_new, v_new, dt) -> new state`` (semi-implicit Euler,
like the cabin); ``body_observed(state, new_state, barrier force) -> {engine_x, engine_vx,
engine_force, engine_crush, mounts_broken}`` for the Trajectory. At most one such mechanism.

Adding a mechanism is one new module with one class: its equation in the docstring, its
parameters as fields (arrays) with units, its effect name (``docs/interface.md``) and a
one-sentence explanation an expert can check.
"""

from __future__ import annotations

from typing import ClassVar

import equinox as eqx


class Mechanism(eqx.Module):
    """An optional piece of physics (override the hooks it changes)."""

    effect: ClassVar[str] = ""
    has_body: ClassVar[bool] = False
    explanation: ClassVar[str] = ""
    units: ClassVar[dict[str, str]] = {}

    def loading_force(self, force, crush, crush_rate, params, vehicle):
        """Return the barrier force (N) on the loading curve; default: unchanged."""
        return force

    def front_blocked(self, blocked, crush, vehicle):
        """Return the blocked fraction (0..1) of the front wheels; default: unchanged."""
        return blocked

    def explain(self, params) -> str:
        """The one-sentence explanation of this mechanism as fitted (``params``: the
        sim.Params it belongs to); default: the class's ``explanation``."""
        return self.explanation

    def parameter_values(self) -> dict[str, tuple[float, str]]:
        """The mechanism's parameters as {name: (value, unit)}, for reports."""
        return {name: (float(getattr(self, name)), unit) for name, unit in self.units.items()}
