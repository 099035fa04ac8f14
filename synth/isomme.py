"""The reference world as a crash lab's sensor recording: an ISO-MME (ISO/TS 13499) folder.

Channels, each sampled at ``rate_hz`` from ``-pre_s`` (the trigger is first contact):

- two rear-seat crossmember X accelerometers (left, right) of the passenger cell,
  ``10SECMLERE00ACX0`` / ``10SECMRIRE00ACX0``, in g, forward positive;
- two engine X accelerometers (top, bottom), ``10ENGNTO0000ACX0`` / ``10ENGNBO0000ACX0``;
- the barrier's load cells, ``B0LOMA<row><col>00FOX0`` in N (compressive positive), four
  cells sharing the barrier force in fixed random proportions.

Each accelerometer has its own white noise and a small offset, as real ones do; the
header's impact speed carries a speed trap's error. Written by this module alone (the
reference world never imports ``identify``), read by ``identify``'s ISO-MME reader.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

G0 = 9.80665  # m/s^2 per g


def _channel_text(name: str, code: str, unit: str, t0: float, dt: float, values: np.ndarray) -> str:
    head = [f"{'Name of the channel':<28}:{name}",
            f"{'Laboratory channel code':<28}:{code}",
            f"{'Channel code':<28}:{code}",
            f"{'Direction':<28}:X",
            f"{'Unit':<28}:{unit}",
            f"{'Channel frequency class':<28}:NOVALUE",
            f"{'Data status':<28}:ok",
            f"{'Time of first sample':<28}:{t0:.6f}",
            f"{'Sampling interval':<28}:{dt:.8f}",
            f"{'Number of samples':<28}:{len(values)}"]
    return "\n".join(head) + "\n" + "\n".join(f"{v:.7g}" for v in values) + "\n"


def write_isomme(folder: Path, number: str, motion, mass_kg: float, rng: np.random.Generator,
                 pre_s: float = 0.02, accel_noise_g: float = 0.3, force_noise_n: float = 1500.0,
                 speed_trap_sigma_kmh: float = 0.1, title: str = "") -> dict:
    """Write ``motion`` (a :class:`synth.physics.RefMotion` sampled at the recording's rate)
    as an ISO-MME test in ``folder`` (which must exist and be empty).

    Parameters
    ----------
    folder : Path
    number : str
        Test number: the file stem.
    motion : RefMotion
        ``t`` (s, from 0 at contact, constant step), ``cabin_accel_x``, ``engine_accel_x``
        (m/s^2, forward positive), ``force_barrier`` (N), ``v0`` (m/s).
    mass_kg : float
        Test mass for the header, kg.
    rng : numpy Generator
        Noise, offsets, the load cells' shares and the speed trap's error.
    pre_s : float
        Recorded time before contact, s (the car at constant speed: no acceleration).
    accel_noise_g, force_noise_n : float
        One-sigma white noise per sample of each accelerometer (g) and load cell (N).
    speed_trap_sigma_kmh : float
        One-sigma error of the header's impact speed, km/h.

    Returns
    -------
    dict
        What was written: ``mme`` (file name), ``header_speed_mps``, ``rate_hz``,
        ``channels`` (code -> description), ``noise``.
    """
    t = np.asarray(motion.t, dtype=float)
    dt = float(np.median(np.diff(t)))
    n_pre = int(round(pre_s / dt))
    t0 = -n_pre * dt

    def padded(a):
        return np.concatenate([np.zeros(n_pre), np.asarray(a, dtype=float)])

    cabin, engine, force = padded(motion.cabin_accel_x), padded(motion.engine_accel_x), padded(motion.force_barrier)
    rows = []
    for side, label in (("LE", "left"), ("RI", "right")):
        offset = rng.normal(0.0, 0.05)
        values = cabin / G0 + offset + rng.normal(0.0, accel_noise_g, cabin.size)
        rows.append((f"10SECM{side}RE00ACX0", f"Rear seat crossmember {label} X acceleration", "g", values))
    for pos, label in (("TO", "top"), ("BO", "bottom")):
        offset = rng.normal(0.0, 0.05)
        values = engine / G0 + offset + rng.normal(0.0, accel_noise_g, engine.size)
        rows.append((f"10ENGN{pos}0000ACX0", f"Engine {label} X acceleration", "g", values))
    shares = rng.dirichlet(np.full(4, 8.0))
    for k, share in enumerate(shares):
        values = share * force + rng.normal(0.0, force_noise_n, force.size)
        rows.append((f"B0LOMA{k // 2:02d}{k % 2:02d}00FOX0", f"Barrier load cell row {k // 2} column {k % 2} X force", "N", values))
    header_speed = float(motion.v0 + rng.normal(0.0, speed_trap_sigma_kmh / 3.6))
    (folder / "Channel").mkdir()
    mme = [f"{'Data format edition number':<28}:1.6",
           f"{'Laboratory test ref. number':<28}:{number}",
           f"{'Title':<28}:{title or number}",
           f"{'Number of test objects':<28}:2",
           f"{'Velocity test object 1':<28}:{header_speed:.4f}",
           f"{'Mass test object 1':<28}:{mass_kg:.1f}",
           f"{'Comments':<28}:synthetic test of the reference world (identify synth)"]
    (folder / f"{number}.mme").write_text("\n".join(mme) + "\n", encoding="latin-1")
    chn = [f"{'Instrumentation standard':<28}:ISO 6487", f"{'Number of channels':<28}:{len(rows)}"]
    for k, (code, name, unit, values) in enumerate(rows, start=1):
        chn.append(f"{'Name of channel ' + format(k, '03d'):<28}:{code} / {name}")
        (folder / "Channel" / f"{number}.{k:03d}").write_text(_channel_text(name, code, unit, t0, dt, values),
                                                             encoding="latin-1")
    (folder / "Channel" / f"{number}.chn").write_text("\n".join(chn) + "\n", encoding="latin-1")
    return {"mme": f"{number}.mme", "header_speed_mps": header_speed, "rate_hz": 1.0 / dt,
            "pre_trigger_s": n_pre * dt, "channels": {code: name for code, name, _, _ in rows},
            "noise": {"accelerometer_g": accel_noise_g, "load_cell_n": force_noise_n,
                      "speed_trap_kmh": speed_trap_sigma_kmh},
            "load_cell_shares": [float(s) for s in shares]}
