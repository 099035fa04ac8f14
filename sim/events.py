"""Event times of a simulated trajectory: wheel blocking, rear lift, end of compression."""

from __future__ import annotations

import numpy as np


def _crossings(t, signal, level):
    """Times (s) where ``signal`` crosses ``level`` upwards and downwards, interpolated linearly."""
    s = np.asarray(signal, dtype=float) - level
    above = s > 0
    ups, downs = [], []
    for i in np.flatnonzero(above[1:] != above[:-1]):
        frac = s[i] / (s[i] - s[i + 1])
        ti = t[i] + frac * (t[i + 1] - t[i])
        (ups if above[i + 1] else downs).append(float(ti))
    return ups, downs


def events_ms(traj) -> dict[str, float | None]:
    """Event times in ms after first contact (None where an event did not happen).

    - ``front_wheel_block`` / ``front_wheel_unblock``: the blocked fraction of the front
      wheels passes 0.5 upwards / downwards afterwards;
    - ``rear_wheel_lift`` / ``rear_wheel_touchdown``: the rear axle's contact margin turns
      negative / positive again (the first lift and the landing that follows);
    - ``compression_end``: the crush reaches its maximum (the crush rate's zero, interpolated);
    - ``separation``: the contact force falls to zero after the maximum crush.
    """
    t = np.asarray(traj.t, dtype=float)
    out: dict[str, float | None] = {}

    ups, downs = _crossings(t, traj.front_blocked, 0.5)
    out["front_wheel_block"] = ups[0] * 1e3 if ups else None
    later = [d for d in downs if ups and d > ups[0]]
    out["front_wheel_unblock"] = later[0] * 1e3 if later else None

    ups, downs = _crossings(t, -np.asarray(traj.rear_margin), 0.0)
    out["rear_wheel_lift"] = ups[0] * 1e3 if ups else None
    later = [d for d in downs if ups and d > ups[0]]
    out["rear_wheel_touchdown"] = later[0] * 1e3 if later else None

    crush = np.asarray(traj.crush, dtype=float)
    i = int(np.argmax(crush))
    if 0 < i < len(t) - 1:
        # The crush rate falls to zero at the maximum: the CG's velocity, sampled, plus the
        # rate of the smooth pitch part of the crush (crush - x = dz' sin(pitch)), by
        # central differences. The contact force drops when the crush turns (the unloading
        # curve starts below the loading curve), so the rate has a kink at its zero:
        # extrapolate the last two loading samples linearly, not across the kink.
        lever = crush - np.asarray(traj.x, dtype=float)
        rate = np.asarray(traj.vx, dtype=float) + np.gradient(lever, t)
        k = i if rate[i] > 0 else i - 1  # last loading sample
        dt = t[1] - t[0]
        slope = (rate[k] - rate[k - 1]) / dt if k > 0 else 0.0
        step = -rate[k] / slope if slope < 0 else 0.5 * dt
        out["compression_end"] = float((t[k] + min(max(step, 0.0), dt)) * 1e3)
    else:
        out["compression_end"] = None

    force = np.asarray(traj.force, dtype=float)
    after = np.flatnonzero((np.arange(len(t)) > i) & (force <= 0.0))
    out["separation"] = float(t[after[0]] * 1e3) if len(after) and i > 0 else None
    return out
