"""Scalar outputs of a simulated impact that an expert reads off, as differentiable functions.

Each function takes a :class:`sim.Trajectory` (one run, arrays of shape (n,)) and returns a
float64 scalar in SI units, ``nan`` where the quantity does not exist in the simulated span
(an event that does not happen, a maximum crush not reached before the end). They are pure
JAX, so they work under ``jit`` and ``vmap`` and can be differentiated with respect to every
parameter of the simulation (``jax.jacfwd``): quantities read at a sample index (an argmax,
a first crossing) are interpolated between samples with the index held fixed, so their
derivative is the derivative of the interpolation.

    from sim import load_vehicle, named_params, simulate
    from sim.outputs import expert_outputs
    traj = simulate(named_params("paper_identified"), load_vehicle("audi_a4"), 15.64)
    expert_outputs(traj)["max_crush"]      # about 0.648 m

Definitions (the event times are those of :func:`sim.events_ms`):

- ``max_crush`` (m): vertex of the parabola through the last three samples on the loading
  curve (the crush curve is kinked at its maximum, where the force drops to the unloading
  line, so only one side of it is smooth);
- ``time_of_max_crush`` (s): the time of that vertex (the end of compression; within a
  fraction of a millisecond of ``events_ms``'s ``compression_end``, which fits a parabola
  across the kink);
- ``rebound_speed`` (m/s): the CG's horizontal speed away from the barrier, ``-vx``, at the
  first output sample after the maximum crush at which the contact force is zero
  (separation);
- ``x_at_<t>ms`` (m): CG displacement x at the chosen time, linearly interpolated;
- ``front_wheel_block_time`` / ``front_wheel_unblock_time`` (s): the blocked fraction of the
  front wheels crosses 0.5 upwards / then downwards (``nan`` without a
  :class:`sim.FrontWheelBlock` mechanism);
- ``rear_wheel_lift_time`` / ``rear_wheel_touchdown_time`` (s): the rear axle's contact
  margin turns negative / then positive again.
"""

from __future__ import annotations

import jax.numpy as jnp

UNITS = {
    "max_crush": "m",
    "time_of_max_crush": "s",
    "rebound_speed": "m/s",
    "front_wheel_block_time": "s",
    "front_wheel_unblock_time": "s",
    "rear_wheel_lift_time": "s",
    "rear_wheel_touchdown_time": "s",
}
DEFAULT_TIMES = (0.05, 0.1, 0.15, 0.2, 0.25, 0.3)  # s, the paper's Fig. 7 instants


def _crush_peak(t, crush, crush_max):
    """(time (s), value (m)) of the largest crush, from the loading side only.

    The contact force drops when the crush stops growing (loading -> unloading line), so the
    crush curve is smooth before its maximum and kinked at it: a parabola through samples on
    both sides is biased towards the nearer sample. Instead the parabola goes through the
    last three samples on the loading curve (crush at its running maximum) and its vertex,
    which lies within one interval after the last of them, is the maximum. Both ``nan`` when
    the crush is still growing at the end of the span (or peaks in the first two samples).
    """
    n = crush.shape[0]
    loading = (crush >= crush_max) & (crush > 0.0)
    i = jnp.max(jnp.where(loading, jnp.arange(n), -1))
    inside = (i >= 2) & (i < n - 1)
    j = jnp.clip(i, 2, n - 1)
    y0, y1, y2 = crush[j - 2], crush[j - 1], crush[j]
    curvature = y0 - 2.0 * y1 + y2  # 2 a, per sample^2
    ok = inside & (curvature < 0.0)
    safe = jnp.where(ok, curvature, -1.0)
    shift = 0.5 * (y0 - y2) / safe  # vertex, in samples from j - 1
    peak = y1 - 0.125 * (y2 - y0) ** 2 / safe
    time = t[j - 1] + shift * (t[1] - t[0])
    return jnp.where(ok, time, jnp.nan), jnp.where(ok, peak, jnp.nan)


def max_crush(traj):
    """m, the largest crush depth (parabolic vertex on the loading side, between samples);
    ``nan`` if the crush is still growing at the end of the simulated span."""
    return _crush_peak(traj.t, traj.crush, traj.crush_max)[1]


def time_of_max_crush(traj):
    """s, time of the largest crush (the end of compression), parabolic interpolation
    on the loading side; ``nan`` if the crush is still growing at the end of the span."""
    return _crush_peak(traj.t, traj.crush, traj.crush_max)[0]


def rebound_speed(traj):
    """m/s, the CG's horizontal speed away from the barrier (``-vx``) at separation: the
    first output sample after the maximum crush with zero contact force; ``nan`` if the car
    is still in contact at the end of the span."""
    n = traj.t.shape[0]
    i = jnp.argmax(traj.crush)
    free = (jnp.arange(n) > i) & (traj.force <= 0.0)
    found = jnp.any(free)
    j = jnp.argmax(free)
    return jnp.where(found, -traj.vx[j], jnp.nan)


def x_at(traj, time):
    """m, CG displacement x at ``time`` (s, inside the simulated span), linear interpolation."""
    return jnp.interp(time, traj.t, traj.x)


def crossing_time(t, signal, after=None):
    """First time (s) ``signal`` crosses zero, linearly interpolated between samples.

    Parameters
    ----------
    t : (n,) s, sample times.
    signal : (n,) any unit; an upward crossing is ``signal[i] <= 0 < signal[i + 1]``.
    after : s or None; if given, only crossings in intervals that start after this time
        count (``nan`` counts as "never", so no crossing is found).

    Returns
    -------
    s, scalar: the interpolated crossing time, or ``nan`` if there is none. Differentiable
    with respect to ``signal`` (the crossing interval is held fixed).
    """
    up = (signal[:-1] <= 0.0) & (signal[1:] > 0.0)
    if after is not None:
        up = up & (t[:-1] > after)
    found = jnp.any(up)
    i = jnp.argmax(up)
    s0, s1 = signal[i], signal[i + 1]
    den = jnp.where(found, s1 - s0, 1.0)
    time = t[i] + (-s0 / den) * (t[i + 1] - t[i])
    return jnp.where(found, time, jnp.nan)


def front_wheel_block_time(traj):
    """s, the front wheels' blocked fraction first passes 0.5 upwards; ``nan`` if never."""
    return crossing_time(traj.t, traj.front_blocked - 0.5)


def front_wheel_unblock_time(traj):
    """s, the blocked fraction falls below 0.5 after blocking; ``nan`` if never."""
    block = front_wheel_block_time(traj)
    return crossing_time(traj.t, 0.5 - traj.front_blocked, after=block)


def rear_wheel_lift_time(traj):
    """s, the rear axle's contact margin first turns negative (wheels leave the ground)."""
    return crossing_time(traj.t, -traj.rear_margin)


def rear_wheel_touchdown_time(traj):
    """s, the rear wheels land after lifting (the margin turns positive again)."""
    lift = rear_wheel_lift_time(traj)
    return crossing_time(traj.t, traj.rear_margin, after=lift)


def time_label(time: float) -> str:
    """Output name of ``x_at(time)``: ``x_at_50ms`` for 0.05 s."""
    ms = time * 1e3
    return f"x_at_{ms:g}ms".replace(".", "p")


def output_names(times=DEFAULT_TIMES) -> list[str]:
    """Names of :func:`expert_outputs`, in order."""
    return ["max_crush", "time_of_max_crush", "rebound_speed"] + [time_label(s) for s in times] + [
        "front_wheel_block_time",
        "front_wheel_unblock_time",
        "rear_wheel_lift_time",
        "rear_wheel_touchdown_time",
    ]


def output_units(times=DEFAULT_TIMES) -> dict[str, str]:
    """Unit of each output of :func:`expert_outputs`."""
    return {name: UNITS.get(name, "m") for name in output_names(times)}


def expert_outputs(traj, times=DEFAULT_TIMES) -> dict:
    """All outputs above as {name: scalar}, in the order of :func:`output_names`.

    Parameters
    ----------
    traj : sim.Trajectory of one run.
    times : s, the instants at which x is reported (static Python floats); times after the
        end of the span give the last sample's x, so keep them inside it.
    """
    peak_time, peak = _crush_peak(traj.t, traj.crush, traj.crush_max)
    block = front_wheel_block_time(traj)
    lift = rear_wheel_lift_time(traj)
    out = {"max_crush": peak, "time_of_max_crush": peak_time, "rebound_speed": rebound_speed(traj)}
    for s in times:
        out[time_label(s)] = x_at(traj, s)
    out["front_wheel_block_time"] = block
    out["front_wheel_unblock_time"] = crossing_time(traj.t, 0.5 - traj.front_blocked, after=block)
    out["rear_wheel_lift_time"] = lift
    out["rear_wheel_touchdown_time"] = crossing_time(traj.t, traj.rear_margin, after=lift)
    return out


def output_vector(traj, times=DEFAULT_TIMES):
    """The outputs of :func:`expert_outputs` stacked into one (n_outputs,) array."""
    return jnp.stack(list(expert_outputs(traj, times).values()))
