"""A simulated trajectory as the CSV of ``identify simulate`` (``docs/interface.md``)."""

from __future__ import annotations

import io

import numpy as np

# (column, Trajectory attribute, scale to the column's unit); the first eight are fixed by
# the interface, the rest are extra channels an expert may want.
COLUMNS = (
    ("t_ms", "t", 1e3),
    ("x_m", "x", 1.0),
    ("z_m", "z", 1.0),
    ("pitch_rad", "pitch", 1.0),
    ("crush_m", "crush", 1.0),
    ("force_N", "force", 1.0),
    ("vx_mps", "vx", 1.0),
    ("front_wheel_angle_rad", "front_wheel_angle", 1.0),
    ("rear_wheel_angle_rad", "rear_wheel_angle", 1.0),
    ("front_normal_N", "front_normal", 1.0),
    ("rear_normal_N", "rear_normal", 1.0),
)


def trajectory_csv(traj) -> str:
    """Return the CSV text: the columns above plus 0/1 columns ``front_wheel_blocked``
    (blocked fraction above 0.5) and ``rear_wheel_airborne``, one row per output sample."""
    names = [c[0] for c in COLUMNS] + ["front_wheel_blocked", "rear_wheel_airborne"]
    data = [np.asarray(getattr(traj, attr)) * scale for _, attr, scale in COLUMNS]
    data.append((np.asarray(traj.front_blocked) > 0.5).astype(int))
    data.append(np.asarray(traj.rear_airborne).astype(int))
    buf = io.StringIO()
    buf.write(",".join(names) + "\n")
    for row in zip(*data):
        buf.write(",".join(f"{v:.6g}" if isinstance(v, float | np.floating) else str(v) for v in row) + "\n")
    return buf.getvalue()
