"""Regenerate the sample films in this folder (deterministic: fixed seeds).

    python data/samples/make_samples.py

``a4_paper.mp4``: Audi A4 (data/vehicles/audi_a4.toml) into a rigid barrier at 56.3 km/h,
simulated with the ``paper_identified`` parameters and the base model's engine on its mounts
(``identify.recordings.synthetic.simulate_and_render``), 30 frames of approach at
constant speed before first contact and 300 ms after it, 1000 fps, 1280x512 px at about
4.6 mm/px in the car plane, mild noise (1.5 grey levels), motion blur (0.3 of the frame
interval, 3 sub-frames), a fixed target on the barrier. Truth beside it: ``a4_paper.truth.json`` (contact frame, impact
speed, m/px, camera, simulated event times) and ``a4_paper.truth.csv`` (per frame: pose,
crush, wheel angles and heights, every target's pixel centre).
"""

from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent.parent))

from identify.recordings.synthetic import simulate_and_render  # noqa: E402
from synth.scene import Effects  # noqa: E402


def main() -> None:
    out = HERE / "a4_paper.mp4"
    meta = simulate_and_render(
        "audi_a4", "paper_identified", 56.3, out, duration=0.3,
        frames_before=30, width=1280, height=512, barrier_target=True,
        effects=Effects(noise_sigma=1.5, blur_substeps=3, exposure=0.3, seed=1),
    )
    size_mb = out.stat().st_size / 1e6
    print(f"{out.name}: {meta['n_frames']} frames, contact frame {meta['contact_frame']}, "
          f"{1000 * meta['m_per_px_car_plane']:.2f} mm/px, {size_mb:.1f} MB")


if __name__ == "__main__":
    main()
