"""Regenerate the discovery demonstration films (deterministic: fixed seeds).

    python data/demos/make_demos.py [NAME ...]

Each film: Audi A4 (data/vehicles/audi_a4.toml) into a rigid barrier at 56.3 km/h,
simulated with the ``paper_identified`` parameters plus the hidden mechanisms listed in
``DEMOS`` (the truth, also written to ``<name>.truth.json`` under "hidden"), 30 frames of
approach and 300 ms after contact at 1000 fps, 640x320 px, mild noise and motion blur as
the sample film. The tool is not told what is hidden; README.md lists it.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent.parent))

# name -> hidden mechanisms: (effect, {field: value}); "at_tyre" places the block where the
# crush reaches the front tyre (front overhang minus wheel radius).
DEMOS = {
    "a4_zone": [("stiffness_zone", {"depth": 0.35, "k_zone": 3.5e6})],
    "a4_wheel_block": [("front_wheel_block", "at_tyre")],
    "a4_zone_and_block": [("stiffness_zone", {"depth": 0.40, "k_zone": 2.5e6}), ("front_wheel_block", {"depth": 0.50})],
    "a4_plain": [],
}
SPEED_KMH = 56.3


def hidden_mechanisms(spec, vehicle):
    """The sim mechanisms of a DEMOS entry."""
    import jax.numpy as jnp

    from sim import MECHANISMS

    out = []
    for effect, fields in spec:
        cls = MECHANISMS[effect]
        if fields == "at_tyre":
            out.append(cls.at_tyre(vehicle))
        else:
            out.append(cls(**{k: jnp.asarray(float(v)) for k, v in fields.items()}))
    return tuple(out)


def make(name: str) -> dict:
    import dataclasses

    import jax
    import numpy as np

    jax.config.update("jax_enable_x64", True)
    from identify.recordings.synthetic import TRAJECTORY_FIELDS, render_crash
    from sim import events_ms, load_vehicle, named_params, simulate
    from synth.render import update_truth
    from synth.scene import Effects

    vehicle = load_vehicle("audi_a4")
    mechanisms = hidden_mechanisms(DEMOS[name], vehicle)
    params = dataclasses.replace(named_params("paper_identified"), mechanisms=mechanisms)
    speed = SPEED_KMH / 3.6
    traj = simulate(params, vehicle, speed=speed, duration=0.3)
    arrays = {f: np.asarray(getattr(traj, f)) for f in TRAJECTORY_FIELDS + ("front_margin", "rear_margin")}
    out = HERE / f"{name}.mp4"
    render_crash("audi_a4", arrays, out, speed=speed, frames_before=30, width=640, height=320,
                 barrier_target=True, effects=Effects(noise_sigma=0.6, blur_substeps=3, exposure=0.3, seed=1))
    hidden = [{"effect": m.effect, "parameters": m.parameter_values()} for m in mechanisms]
    events = {k: (None if v is None else float(v)) for k, v in events_ms(traj).items()}
    meta = update_truth(out, {"vehicle": "audi_a4", "params": "paper_identified", "impact_speed_kmh": SPEED_KMH,
                              "hidden": hidden, "events_ms": events})
    print(f"{out.name}: {out.stat().st_size / 1e6:.2f} MB, hidden {json.dumps(hidden)}")
    return meta


def main(names) -> None:
    for name in names or DEMOS:
        make(name)


if __name__ == "__main__":
    main(sys.argv[1:])
