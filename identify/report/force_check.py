"""The independent check of a fit: the barrier's own measurement of the contact force.

The fit sees only the vehicle's motion. A load-cell barrier measures the contact force
itself; comparing the model's predicted force with it is a test nobody can tune to:

- :func:`measured_force`: the sum of the barrier's X load cells, offset-free, filtered
  with SAE J211 CFC 60 (as J211 prescribes for barrier forces), times from first contact;
- :func:`momentum_check`: the force's impulse against the test mass times the vehicle's
  change of velocity (a check of the recording itself), for the averaged motion and for
  each accelerometer alone (their spread is how well the recording knows that change);
- :func:`rigid_body_force`: the test mass times the measured deceleration, the force a
  rigid car moving exactly as the accelerometers say would feel; scored against the load
  cells like a prediction, it shows how much of the force's mismatch no one-body model
  fitted to the motion can remove (the car is not rigid: its engine and cabin stop at
  different times);
- :func:`two_body_force`: the same for a car of two rigid bodies, the engine (its own X
  accelerometers, a given mass) and the cabin (the rest of the test mass): what a model of a
  cabin and an engine fitting both measured motions exactly would predict; and
  :func:`engine_mass_matching_the_barrier`, the engine mass for which that curve comes
  nearest the load cells (least squares) and how near: the floor under any such model's
  RMS error;
- :func:`compare_forces`: peak force and impulse errors, the RMS error over the peak
  (NRMSE) and the ISO/TS 18571 objective rating (:func:`iso18571`);
- :func:`write_forces_csv`, :func:`plot_force_time`, :func:`plot_force_crush`: the
  ``forces.csv`` of ``docs/interface.md`` and two PNG plots.
- :func:`model_force`: a simulated force on the measurement's clock, CFC-filtered as the cells;
- :func:`check_forces`: the comparison, ``forces.csv`` and the plots into a results folder;
- :func:`force_check_document`: one call for the fit command, the measured force, the
  momentum check and :func:`check_forces`, returned as a JSON-ready dictionary for
  ``result.json`` (``"force_check"``).

ISO/TS 18571:2014 rating, as implemented here (all four metrics and the overall score,
with the standard's default parameters; both curves resampled to 10 kHz over the
evaluation interval):

- corridor score Z: inner and outer corridors of half-width a0 = 0.05 and b0 = 0.5 times
  max |reference|; a sample scores 1 inside the inner corridor, 0 outside the outer one,
  ((b0 - |diff|) / (b0 - a0))^kz between (kz = 2); Z is the mean over the samples;
- phase score P: the comparison curve is shifted by up to 20 % of the interval (left
  before right, the smallest shift on ties) to maximise the cross-correlation with the
  reference; P = ((0.2 N - |n|) / (0.2 N))^kp (kp = 1), 0 beyond the limit;
- magnitude score M: the shifted curves are aligned by dynamic time warping (squared
  differences, symmetric steps, Sakoe-Chiba band of 10 % of N); the magnitude error is
  sum |C_w - T_w| / sum |T_w| and M = ((0.5 - error) / 0.5)^km (km = 1), 0 beyond 0.5;
- slope score S: derivatives of the shifted curves by central differences, smoothed by a
  9-point moving average (1, 3, 5, 7 points at the ends); slope error
  sum |C' - T'| / sum |T'| and S = (2 - error) / 2, 0 beyond 2;
- overall rating R = 0.4 Z + 0.2 P + 0.2 M + 0.2 S (ISO 18571's weights).

Checked against objective_rating_metrics 1.3 (PyPI, an independent implementation; not a
dependency): the same five numbers to 1e-7 on shifted, scaled and rippled pulses
(``tests/test_force_check.py``). Not included: the standard's verbal rating classes. The
metric is defined for non-ambiguous signals, which a barrier force is.
"""

from __future__ import annotations

import csv
import math
import os
import tempfile
import textwrap
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from identify.errors import UserError

__all__ = ["BarrierForce", "Iso18571", "ForceComparison", "measured_force", "momentum_check", "rigid_body_force",
           "two_body_force", "engine_mass_matching_the_barrier",
           "iso18571", "compare_forces", "end_of_contact", "model_force", "write_forces_csv",
           "plot_force_time", "plot_force_crush", "check_forces", "force_check_document"]

ISO_RATE_HZ = 10_000.0  # ISO/TS 18571 rates curves sampled at 10 kHz
CONTACT_LEVEL = 0.02  # contact ends when the force stays below this fraction of its peak


@dataclass(frozen=True)
class BarrierForce:
    """The measured contact force.

    Attributes
    ----------
    t : (n,) float64
        Time since first contact, s (negative before it).
    force : (n,) float64
        Summed barrier X force, N, compressive positive, CFC ``cfc``.
    cfc : int
    n_cells : int
        Number of load cells summed.
    """

    t: np.ndarray
    force: np.ndarray
    cfc: int
    n_cells: int


@dataclass(frozen=True)
class Iso18571:
    """ISO/TS 18571 scores (each 0..1, 1 = identical) and the phase shift found (s)."""

    corridor: float
    phase: float
    magnitude: float
    slope: float
    overall: float
    shift_s: float


@dataclass(frozen=True)
class ForceComparison:
    """Measured vs predicted contact force.

    Attributes
    ----------
    peak_measured_N, peak_predicted_N : float
    peak_error : float
        (predicted - measured) / measured peak, 1.
    peak_time_measured_ms, peak_time_predicted_ms : float
    impulse_measured_Ns, impulse_predicted_Ns : float
        Integrals over the evaluation window, N s.
    impulse_error : float
        (predicted - measured) / measured impulse, 1.
    window_ms : tuple of float
        Evaluation interval, ms after contact.
    iso18571 : Iso18571
    nrmse : float
        Root-mean-square of (predicted - measured) over the window, over the measured peak, 1.
    """

    peak_measured_N: float
    peak_predicted_N: float
    peak_error: float
    peak_time_measured_ms: float
    peak_time_predicted_ms: float
    impulse_measured_Ns: float
    impulse_predicted_Ns: float
    impulse_error: float
    window_ms: tuple[float, float]
    iso18571: Iso18571
    nrmse: float

    def to_dict(self) -> dict:
        """JSON-ready dictionary (the ISO scores nested under ``iso18571``)."""
        d = asdict(self)
        d["window_ms"] = list(self.window_ms)
        return d


def measured_force(test, t_contact: float | None = None, cfc: int = 60) -> BarrierForce:
    """Summed, filtered barrier force of a sensor test, times from first contact.

    Parameters
    ----------
    test : identify.recordings.SensorTest
        With barrier channels.
    t_contact : float, optional
        First contact on the recording's time base, s; default
        ``identify.recordings.contact_time(test)``.
    cfc : int
        SAE J211 class (60 for barrier forces).

    Returns
    -------
    BarrierForce
    """
    from identify.recordings.motion import combine, contact_time, filter_cfc

    if not test.barrier:
        raise UserError(f"{test.source}: the test has no barrier load cells; the force check needs them")
    t, f = combine(test.barrier, "sum", "barrier forces", test.source)
    if t_contact is None:
        t_contact, _ = contact_time(test)
    ff = filter_cfc(f, 1.0 / np.median(np.diff(t)), cfc)
    return BarrierForce(t=t - t_contact, force=ff, cfc=cfc, n_cells=len(test.barrier))


def end_of_contact(t: np.ndarray, force: np.ndarray, level: float = CONTACT_LEVEL) -> float:
    """Last time (s) the force is above ``level`` times its peak."""
    f = np.asarray(force, dtype=float)
    above = np.flatnonzero(f > level * np.max(f))
    if len(above) == 0:
        raise UserError("the force never rises above zero")
    return float(np.asarray(t)[above[-1]])


def rigid_body_force(test, t_contact: float | None = None, cfc: int = 60) -> tuple[np.ndarray, np.ndarray]:
    """The contact force a rigid car of the test mass needs to move as its accelerometers say.

    F = -m * a, with a the averaged vehicle X acceleration (offset-free) filtered with the
    load cells' class. Any one-body model's contact force is its mass times its own
    acceleration, so a model fitting the measured motion exactly predicts this curve: scored
    against the load cells it tells what part of the force mismatch comes from the car not
    being rigid rather than from the model's force law.

    Parameters
    ----------
    test : identify.recordings.SensorTest
        With a test mass.
    t_contact : float, optional
        First contact on the recording's time base, s; default
        ``identify.recordings.contact_time(test)``.
    cfc : int
        SAE J211 class (60, as the barrier force).

    Returns
    -------
    t : (n,) float64
        Time since first contact, s.
    force : (n,) float64
        N, positive when the car decelerates.
    """
    from identify.recordings.motion import contact_time

    t, a = _cabin_acceleration(test, cfc, "the rigid-body force")
    if t_contact is None:
        t_contact, _ = contact_time(test)
    return t - t_contact, -float(test.mass_kg) * a


def _cabin_acceleration(test, cfc: int, needed_by: str) -> tuple[np.ndarray, np.ndarray]:
    """(t (s, the recording's clock), the vehicle accelerometers' mean (m/s^2), offset-free,
    filtered with ``cfc``) of a test that has a mass (``needed_by`` names what needs it)."""
    from identify.recordings.motion import combine, filter_cfc

    if not test.mass_kg:
        raise UserError(f"{test.source}: the header gives no test mass; {needed_by} needs it")
    t, a = combine(test.vehicle, "mean", "vehicle accelerations", test.source)
    return t, filter_cfc(a, 1.0 / np.median(np.diff(t)), cfc)


def _two_body_parts(test, t_contact: float, cfc: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t (s since contact), -m a_cabin (N), a_cabin - a_engine (m/s^2)) on the engine
    channels' clock, both accelerations offset-free and filtered with ``cfc``: the two-body
    force for an engine of mass m_e is the second plus m_e times the third."""
    from identify.recordings.motion import combine, filter_cfc

    t, a = _cabin_acceleration(test, cfc, "the two-body force")
    if not test.engine:
        raise UserError(f"{test.source}: the test has no engine accelerometer; the two-body force needs one")
    te, ae = combine(test.engine, "mean", "engine accelerations", test.source)
    cabin = np.interp(te, t, a)
    engine = filter_cfc(ae, 1.0 / np.median(np.diff(te)), cfc)
    return te - t_contact, -float(test.mass_kg) * cabin, cabin - engine


def two_body_force(test, engine_mass_kg: float, t_contact: float | None = None,
                   cfc: int = 60) -> tuple[np.ndarray, np.ndarray]:
    """The contact force a car of two rigid bodies needs to move as its accelerometers say.

    F = -(m - m_e) a_cabin - m_e a_engine: the engine (mass ``engine_mass_kg``) moves as the
    mean of its X accelerometers, the rest of the test mass as the cabin's; the forces between
    the two bodies (mounts, the parts crushed between them) cancel in the sum, so any model of
    a cabin and an engine that fits both measured motions exactly predicts this curve, whatever
    its force laws. With m_e = 0 it is :func:`rigid_body_force`.

    Parameters
    ----------
    test : identify.recordings.SensorTest
        With a test mass and engine channels (``test.engine``, on the vehicle channels' clock).
    engine_mass_kg : float
        kg.
    t_contact : float, optional
        First contact on the recording's time base, s; default
        ``identify.recordings.contact_time(test)``.
    cfc : int
        SAE J211 class (60, as the barrier force).

    Returns
    -------
    t : (n,) float64
        Time since first contact, s; it ends where the engine channels end.
    force : (n,) float64
        N, positive when the car decelerates.
    """
    from identify.recordings.motion import contact_time

    if t_contact is None:
        t_contact, _ = contact_time(test)
    t, rigid, difference = _two_body_parts(test, t_contact, cfc)
    return t, rigid + float(engine_mass_kg) * difference


def engine_mass_matching_the_barrier(force: BarrierForce, test, t_contact: float,
                                     window_s: tuple[float, float]) -> tuple[float, float]:
    """The engine mass (kg, within 0 and the test mass) for which :func:`two_body_force` comes
    nearest the load cells over ``window_s`` (s since contact; least squares on the 10 kHz
    grid of :func:`compare_forces`), and that curve's RMS error over the measured peak (1).

    The two-body force is linear in the engine mass, F_r + m_e D, so the best mass is
    -sum(D (F_r - F_measured)) / sum(D^2), clipped to [0, m]. No model of a cabin and an
    engine that fits both motions exactly can predict the load cells with a smaller RMS error.
    """
    t, rigid, difference = _two_body_parts(test, t_contact, force.cfc)
    t0, t1 = window_s
    grid = np.arange(t0, t1 + 0.5 / ISO_RATE_HZ, 1.0 / ISO_RATE_HZ)
    fm = np.interp(grid, force.t, force.force)
    fr, d = np.interp(grid, t, rigid), np.interp(grid, t, difference)
    mass = float(np.clip(-np.sum(d * (fr - fm)) / max(float(np.sum(d * d)), 1e-30), 0.0, float(test.mass_kg)))
    return mass, float(np.sqrt(np.mean((fr + mass * d - fm) ** 2)) / np.max(fm))


def momentum_check(force: BarrierForce, mass_kg: float, t: np.ndarray, v: np.ndarray) -> dict[str, float]:
    """Impulse of the barrier force over the contact against mass times change of velocity.

    Parameters
    ----------
    force : BarrierForce
    mass_kg : float
        Test mass, kg.
    t, v : (m,) float
        Time since contact (s) and the vehicle's velocity (m/s, towards the barrier).

    Returns
    -------
    dict
        ``t_end_ms`` (end of contact), ``impulse_Ns`` (integral of the force from 0 to
        t_end), ``momentum_change_Ns`` (mass * (v(0) - v(t_end))), ``error`` (impulse /
        momentum change - 1).
    """
    tf, f = force.t, force.force
    t_end = end_of_contact(tf[tf >= 0], f[tf >= 0])
    w = (tf >= 0) & (tf <= t_end)
    impulse = float(np.trapezoid(f[w], tf[w]))
    dv = float(np.interp(0.0, t, v) - np.interp(t_end, t, v))
    change = mass_kg * dv
    return {"t_end_ms": t_end * 1e3, "impulse_Ns": impulse, "momentum_change_Ns": change,
            "error": impulse / change - 1.0}


def _shift_search(ref: np.ndarray, cmp: np.ndarray, max_frac: float = 0.2):
    """Shift of ``cmp`` (samples, positive = cmp is late) maximising the correlation."""
    n = len(ref)
    best, best_n = _corr(ref, cmp), 0
    for m in range(1, int(math.floor(n * max_frac)) + 1):
        if n - m < 3:
            break
        left = _corr(ref[:-m], cmp[m:])
        if left > best:
            best, best_n = left, m
        right = _corr(ref[m:], cmp[:-m])
        if right > best:
            best, best_n = right, -m
    return best_n


def _corr(a: np.ndarray, b: np.ndarray) -> float:
    a = a - a.mean()
    b = b - b.mean()
    den = math.sqrt(float(a @ a) * float(b @ b))
    return float(a @ b) / den if den > 0 else -np.inf


def _dtw_path(x: np.ndarray, y: np.ndarray, band: int) -> tuple[np.ndarray, np.ndarray]:
    """Dynamic time warping of equal-length ``x`` and ``y`` (squared differences, steps
    (1,0), (0,1), (1,1) of weight 1) inside the band |i - j| <= ``band``.

    Row by row: D[i, j] = min(m[j], D[i, j-1] + c[i, j]) with m[j] = c[i, j] +
    min(D[i-1, j], D[i-1, j-1]), solved for the whole row at once as
    S[j] + min over l <= j of (m[l] - S[l]), S the running sum of c along the row.
    """
    n = len(x)
    w = int(band)
    k = np.arange(2 * w + 1)
    D = np.full((n, 2 * w + 1), np.inf)
    for i in range(n):
        j = i - w + k
        valid = (j >= 0) & (j < n)
        c = np.where(valid, (x[i] - y[np.clip(j, 0, n - 1)]) ** 2, 0.0)
        if i == 0:
            m = np.where(j == 0, c, np.inf)
        else:
            prev = D[i - 1]
            up = np.concatenate([prev[1:], [np.inf]])  # D[i-1, j]
            m = c + np.minimum(up, prev)  # prev[k] is D[i-1, j-1]
        m = np.where(valid, m, np.inf)
        s = np.cumsum(c)
        row = s + np.minimum.accumulate(m - s)
        D[i] = np.where(valid, row, np.inf)
    i, kk = n - 1, w
    pi, pj = [i], [i - w + kk]
    while i > 0 or (i - w + kk) > 0:
        j = i - w + kk
        cands = []
        if i > 0 and j > 0:
            cands.append((D[i - 1, kk], i - 1, kk))  # diagonal first on ties
        if i > 0 and kk + 1 <= 2 * w:
            cands.append((D[i - 1, kk + 1], i - 1, kk + 1))
        if j > 0 and kk - 1 >= 0:
            cands.append((D[i, kk - 1], i, kk - 1))
        _, i, kk = min(cands, key=lambda c_: c_[0])
        pi.append(i)
        pj.append(i - w + kk)
    return np.array(pi[::-1]), np.array(pj[::-1])


def _smoothed_slope(y: np.ndarray, dt: float) -> np.ndarray:
    d = np.gradient(y, dt)
    out = np.convolve(d, np.ones(9) / 9.0, mode="same")
    for e, n in enumerate((1, 3, 5, 7)):
        out[e] = d[:n].mean()
        out[-1 - e] = d[-n:].mean()
    return out


def iso18571(reference: np.ndarray, comparison: np.ndarray, dt: float = 1.0 / ISO_RATE_HZ) -> Iso18571:
    """ISO/TS 18571 objective rating of ``comparison`` against ``reference``.

    Parameters
    ----------
    reference, comparison : (N,) float
        Curves on one time grid of spacing ``dt`` (the standard asks for 10 kHz) over the
        evaluation interval; any unit, the same for both.
    dt : float
        Sample spacing, s.

    Returns
    -------
    Iso18571
        The four scores, the overall rating and the phase shift (s, positive when the
        comparison lags the reference). Definitions: this module's docstring.
    """
    ref = np.asarray(reference, dtype=float)
    cmp_ = np.asarray(comparison, dtype=float)
    if ref.shape != cmp_.shape or ref.ndim != 1 or len(ref) < 20:
        raise UserError("ISO 18571 needs two curves of the same length on one grid (at least 20 samples)")
    t_norm = float(np.max(np.abs(ref)))
    if not t_norm > 0:
        raise UserError("ISO 18571: the reference curve is zero everywhere")
    n = len(ref)
    a0, b0 = 0.05 * t_norm, 0.5 * t_norm
    diff = np.abs(ref - cmp_)
    zi = np.clip((b0 - diff) / (b0 - a0), 0.0, 1.0) ** 2
    zi[diff < a0] = 1.0
    corridor = float(zi.mean())

    shift = _shift_search(ref, cmp_)
    limit = 0.2 * n
    phase = 1.0 if shift == 0 else max(0.0, (limit - abs(shift)) / limit)
    if shift > 0:
        t_s, c_s = ref[:-shift], cmp_[shift:]
    elif shift < 0:
        t_s, c_s = ref[-shift:], cmp_[:shift]
    else:
        t_s, c_s = ref, cmp_

    pi, pj = _dtw_path(c_s, t_s, int(math.ceil(0.1 * len(t_s))) - 1)
    cw, tw = c_s[pi], t_s[pj]
    den = float(np.sum(np.abs(tw)))
    e_mag = float(np.sum(np.abs(cw - tw))) / den if den > 0 else np.inf
    magnitude = 1.0 if e_mag == 0 else max(0.0, (0.5 - e_mag) / 0.5)

    ds_c, ds_t = _smoothed_slope(c_s, dt), _smoothed_slope(t_s, dt)
    den = float(np.sum(np.abs(ds_t)))
    e_slope = float(np.sum(np.abs(ds_c - ds_t))) / den if den > 0 else np.inf
    slope = 1.0 if e_slope <= 0 else max(0.0, (2.0 - e_slope) / 2.0)

    overall = 0.4 * corridor + 0.2 * phase + 0.2 * magnitude + 0.2 * slope
    return Iso18571(corridor=corridor, phase=phase, magnitude=magnitude, slope=slope,
                    overall=overall, shift_s=shift * dt)


def compare_forces(t: np.ndarray, measured: np.ndarray, t_pred: np.ndarray, predicted: np.ndarray,
                   window_s: tuple[float, float] | None = None) -> ForceComparison:
    """Compare a predicted contact force with the measured one.

    Parameters
    ----------
    t, measured : (n,) float
        Time since contact (s) and measured force (N).
    t_pred, predicted : (m,) float
        Time since contact (s) and predicted force (N); zero outside its span.
    window_s : (float, float), optional
        Evaluation interval, s. Default: from contact to 10 ms after the later of the two
        ends of contact (force below 2 % of its peak for good), within both records.

    Returns
    -------
    ForceComparison
    """
    t = np.asarray(t, dtype=float)
    measured = np.asarray(measured, dtype=float)
    t_pred = np.asarray(t_pred, dtype=float)
    predicted = np.asarray(predicted, dtype=float)
    if window_s is None:
        pos = t >= 0
        end = max(end_of_contact(t[pos], measured[pos]), end_of_contact(t_pred, predicted)) + 0.010
        end = min(end, t[-1], t_pred[-1])
        window_s = (0.0, end)
    t0, t1 = window_s
    if not t1 > t0:
        raise UserError(f"empty force-comparison window {window_s}")
    grid = np.arange(t0, t1 + 0.5 / ISO_RATE_HZ, 1.0 / ISO_RATE_HZ)
    fm = np.interp(grid, t, measured)
    fp = np.interp(grid, t_pred, predicted, left=0.0, right=0.0)
    im, ip = int(np.argmax(fm)), int(np.argmax(fp))
    imp_m = float(np.trapezoid(fm, grid))
    imp_p = float(np.trapezoid(fp, grid))
    return ForceComparison(
        peak_measured_N=float(fm[im]), peak_predicted_N=float(fp[ip]),
        peak_error=float(fp[ip] / fm[im] - 1.0),
        peak_time_measured_ms=float(grid[im] * 1e3), peak_time_predicted_ms=float(grid[ip] * 1e3),
        impulse_measured_Ns=imp_m, impulse_predicted_Ns=imp_p, impulse_error=imp_p / imp_m - 1.0,
        window_ms=(t0 * 1e3, t1 * 1e3), iso18571=iso18571(fm, fp, 1.0 / ISO_RATE_HZ),
        nrmse=float(np.sqrt(np.mean((fp - fm) ** 2)) / fm[im]))


def _atomic_write(path: Path, write) -> None:
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    os.close(fd)
    try:
        write(tmp)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_forces_csv(path: str | Path, t_ms: np.ndarray, measured_N: np.ndarray, predicted_N: np.ndarray) -> None:
    """Write ``forces.csv`` (``t_ms, measured_N, predicted_N``), atomically."""

    def write(tmp):
        with open(tmp, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["t_ms", "measured_N", "predicted_N"])
            for row in zip(t_ms, measured_N, predicted_N):
                w.writerow([f"{row[0]:.3f}", f"{row[1]:.1f}", f"{row[2]:.1f}"])

    _atomic_write(Path(path), write)


def _figure():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_force_time(path, t_ms, measured_N, predicted_N, comparison: ForceComparison | None = None,
                    title: str = "", rigid=None, base=None, base_label: str = "base model, before discovery",
                    two_body=None, two_body_label: str = "") -> None:
    """PNG of measured and predicted force (kN) against time (ms); optional (t_ms, N)
    curves: ``rigid`` (:func:`rigid_body_force`, thin grey), ``two_body``
    (:func:`two_body_force`, thin green, ``two_body_label``) and ``base`` (the base model
    before discovery, or the one-body model beside a two-body one: ``base_label``, dashed)."""
    plt = _figure()
    fig, ax = plt.subplots(figsize=(8, 4.5))
    if rigid is not None:
        ax.plot(rigid[0], np.asarray(rigid[1]) / 1e3, color="0.6", lw=1.0,
                label="test mass x measured deceleration (a rigid car, CFC 60)")
    if two_body is not None:
        ax.plot(two_body[0], np.asarray(two_body[1]) / 1e3, color="tab:green", lw=1.0, label=two_body_label)
    ax.plot(t_ms, np.asarray(measured_N) / 1e3, color="k", label="measured (barrier load cells, CFC 60)")
    if base is not None:
        ax.plot(base[0], np.asarray(base[1]) / 1e3, color="tab:blue", ls="--", lw=1.2,
                label=f"{base_label} (same CFC)")
    ax.plot(t_ms, np.asarray(predicted_N) / 1e3, color="tab:red", label="predicted (model, same CFC)")
    ax.set_xlabel("time after first contact (ms)")
    ax.set_ylabel("contact force (kN)")
    if comparison is not None:
        c = comparison
        ax.set_title((textwrap.fill(title, 90) + "\n" if title else "") +
                     f"peak {c.peak_error:+.1%}, impulse {c.impulse_error:+.1%}, "
                     f"ISO 18571 rating {c.iso18571.overall:.2f}", fontsize=10)
    ax.axhline(0, color="0.8", lw=0.8)
    ax.legend()
    fig.tight_layout()
    _atomic_write(Path(path), lambda tmp: fig.savefig(tmp, format="png", dpi=110))
    plt.close(fig)


def plot_force_crush(path, crush_measured_m, force_measured_N, crush_predicted_m, force_predicted_N,
                     title: str = "", engine=None) -> None:
    """PNG of force (kN) against crush (m), measured and predicted; ``engine`` (engine crush
    (m), engine force (N), structure force (N)) adds each body's own curve of a two-body model."""
    plt = _figure()
    fig, ax = plt.subplots(figsize=(6, 4.5))
    ax.plot(crush_measured_m, np.asarray(force_measured_N) / 1e3, color="k", label="measured (barrier load cells)")
    ax.plot(crush_predicted_m, np.asarray(force_predicted_N) / 1e3, color="tab:red", label="predicted, whole barrier")
    if engine is not None:
        crush_e, force_e, force_s = engine
        ax.plot(crush_predicted_m, np.asarray(force_s) / 1e3, color="tab:orange", ls="--",
                label="predicted, front structure vs cabin crush")
        hit = np.asarray(crush_e) > 0
        ax.plot(np.asarray(crush_e)[hit], np.asarray(force_e)[hit] / 1e3, color="tab:purple", ls=":",
                label="predicted, engine block vs its own crush")
    ax.set_xlabel("crush (m)")
    ax.set_ylabel("contact force (kN)")
    if title:
        ax.set_title(title, fontsize=10)
    ax.legend()
    fig.tight_layout()
    _atomic_write(Path(path), lambda tmp: fig.savefig(tmp, format="png", dpi=110))
    plt.close(fig)


def model_force(traj, contact_time_s: float, cfc: int) -> tuple[np.ndarray, np.ndarray]:
    """A simulated contact force on the measurement's clock, through the load cells' filter.

    J211 compares channels at the same filter class; the model's jump where the crush
    turns is an idealisation a load cell would not show either.

    Parameters
    ----------
    traj : sim.Trajectory
    contact_time_s : float
        Measurement time of the model's first contact, s.
    cfc : int
        SAE J211 class of the load cells.

    Returns
    -------
    t : (n,) float64
        s since the measured first contact.
    force : (n,) float64
        N.
    """
    from identify.recordings.motion import filter_cfc

    tp = np.asarray(traj.t, dtype=float) + contact_time_s
    return tp, filter_cfc(np.asarray(traj.force, dtype=float), 1.0 / float(tp[1] - tp[0]), cfc)


def check_forces(force: BarrierForce, traj, measurement, out_dir: str | Path,
                 contact_time_s: float = 0.0, title: str = "", rigid=None, base=None,
                 base_label: str = "base model, before discovery", two_body=None,
                 two_body_label: str = "") -> ForceComparison:
    """Compare a simulated trajectory's contact force, filtered with the load cells' CFC
    class, with the barrier's; write ``forces.csv``, ``force_time.png`` and
    ``force_crush.png`` into ``out_dir``.

    Parameters
    ----------
    force : BarrierForce
        From :func:`measured_force`.
    traj : sim.Trajectory
        The fitted model's simulation (``t`` from the model's first contact, ``force``,
        ``crush``).
    measurement : identify.recordings.measurement.Measurement
        The measured motion; its ``x_m`` is the measured crush (rigid barrier).
    out_dir : str or Path
        Existing folder.
    contact_time_s : float
        Measurement time of the model's first contact, s (the fit's ``contact_time``):
        model time = measurement time - contact_time_s.
    title : str
        Title of the plots.
    rigid : (t (s), force (N)), optional
        :func:`rigid_body_force`, drawn in the force-time plot for reference.
    base : (t (s), force (N)), optional
        The base model's :func:`model_force` when ``traj`` is a model with discovered
        mechanisms, drawn dashed in the force-time plot.
    two_body : (t (s), force (N)), optional
        :func:`two_body_force`, drawn in the force-time plot with ``two_body_label``.

    Returns
    -------
    ForceComparison
        Over the default window of :func:`compare_forces`, on the measurement's clock.
        ``forces.csv`` holds one row a millisecond of that clock from 0 to the end of the
        shorter record (the prediction is 0 before the model's contact).
    """
    out = Path(out_dir)
    tp, fp = model_force(traj, contact_time_s, force.cfc)
    comparison = compare_forces(force.t, force.force, tp, fp)
    end_all = min(float(force.t[-1]), float(tp[-1]))
    grid = np.arange(0.0, end_all + 1e-9, 1e-3)
    fm_grid = np.interp(grid, force.t, force.force)
    fp_grid = np.interp(grid, tp, fp, left=0.0, right=0.0)
    write_forces_csv(out / "forces.csv", grid * 1e3, fm_grid, fp_grid)

    def on_grid(curve):
        return None if curve is None else (grid * 1e3, np.interp(grid, curve[0], curve[1], left=0.0, right=0.0))

    plot_force_time(out / "force_time.png", grid * 1e3, fm_grid, fp_grid, comparison, title, on_grid(rigid),
                    on_grid(base), base_label, on_grid(two_body), two_body_label)
    end = comparison.window_ms[1] / 1e3
    tm = np.asarray(measurement.t)
    keep = tm <= end
    model = tp <= end
    engine = None
    if float(np.max(np.asarray(traj.engine_force))) > 0.0:  # a two-body model: each body's own curve
        engine = (np.asarray(traj.engine_crush)[model], np.asarray(traj.engine_force)[model],
                  (np.asarray(traj.force) - np.asarray(traj.engine_force))[model])
    plot_force_crush(out / "force_crush.png", np.asarray(measurement.channels["x_m"])[keep],
                     np.interp(tm[keep], force.t, force.force), np.asarray(traj.crush)[model],
                     fp[model], title, engine)
    return comparison


def force_check_document(test, measurement, traj, out_dir: str | Path, contact_time_s: float = 0.0,
                         title: str = "", base=None, base_label: str = "base model, before discovery",
                         engine_mass: tuple[float, str] | None = None) -> dict:
    """Everything the force check produces for a fitted sensor test, in one call.

    Parameters
    ----------
    test : identify.recordings.SensorTest
        With barrier load cells.
    measurement : identify.recordings.measurement.Measurement
        ``identify.recordings.measurement_from_test(test)``: what the fit saw.
    traj : sim.Trajectory
        The fitted model's simulation.
    out_dir : str or Path
        Existing folder: ``forces.csv``, ``force_time.png``, ``force_crush.png`` go there.
    contact_time_s : float
        The fit's contact time (measurement time of the model's first contact), s.
    title : str
        Title of the plots.
    base : (sim.Trajectory, contact time (s)), optional
        The base model's fit, when ``traj`` is a model with discovered mechanisms: scored
        too (``"base_model"``) and drawn in the force-time plot; or the one-body model beside
        a two-body one (``base_label`` says which, also in ``"base_model"["label"]``).
    engine_mass : (kg, where it comes from), optional
        For the two-body reference (:func:`two_body_force`) of a test with engine channels,
        e.g. ``(230.0, "the vehicle file's")``.

    Returns
    -------
    dict
        ``{"load_cells": n, "cfc": 60, **ForceComparison.to_dict()}``, ``"base_model"``
        (its ForceComparison) when ``base`` is given, and, when the test
        has a mass, ``"momentum_check"`` (the recording's own consistency,
        :func:`momentum_check`, with ``"per_accelerometer"``: channel code -> the error
        with that accelerometer's motion alone) and ``"rigid_body"`` (the
        ForceComparison of :func:`rigid_body_force`, what a one-body model fitting the
        motion exactly would score); with ``engine_mass`` and engine channels, ``"two_body"``:
        the ForceComparison of :func:`two_body_force` with ``engine_mass_kg`` and
        ``engine_mass_source``, and ``best_engine_mass_kg`` / ``best_nrmse``
        (:func:`engine_mass_matching_the_barrier`), both over the fitted model's window so that
        they compare with its numbers, or ``{"not_computed": why}`` when the engine channels
        end before that window does.
    """
    from identify.recordings.motion import channel_motions, contact_time

    t_contact, _ = contact_time(test)
    force = measured_force(test, t_contact)
    doc = {"load_cells": force.n_cells, "cfc": force.cfc}
    rigid = None
    if test.mass_kg:
        check = momentum_check(force, test.mass_kg, measurement.t, measurement.channels["vx_mps"])
        tau, each = channel_motions(test, t_contact)
        check["per_accelerometer"] = {code: momentum_check(force, test.mass_kg, tau, v)["error"]
                                      for code, (v, _) in each.items()}
        doc["momentum_check"] = check
        rigid = rigid_body_force(test, t_contact, force.cfc)
        doc["rigid_body"] = compare_forces(force.t, force.force, *rigid).to_dict()
    two_body, two_body_label = None, ""
    if test.mass_kg and test.engine and engine_mass is not None:
        two_body = two_body_force(test, engine_mass[0], t_contact, force.cfc)
        two_body_label = f"cabin + engine of {engine_mass[0]:.0f} kg moving as measured (CFC {force.cfc})"
    base_curve = None
    if base is not None:
        base_curve = model_force(base[0], base[1], force.cfc)
        doc["base_model"] = {"label": base_label, **compare_forces(force.t, force.force, *base_curve).to_dict()}
    comparison = check_forces(force, traj, measurement, out_dir, contact_time_s, title, rigid, base_curve,
                              base_label, two_body, two_body_label)
    doc.update(comparison.to_dict())
    if two_body is not None:  # scored over the fitted model's window, so that the rows compare
        window = (comparison.window_ms[0] / 1e3, comparison.window_ms[1] / 1e3)
        if two_body[0][-1] < window[1]:
            doc["two_body"] = {"not_computed": f"the engine channels end {two_body[0][-1] * 1e3:.1f} ms after"
                                               f" contact, before the comparison's {window[1] * 1e3:.1f} ms"}
        else:
            best, best_nrmse = engine_mass_matching_the_barrier(force, test, t_contact, window)
            doc["two_body"] = {"engine_mass_kg": float(engine_mass[0]), "engine_mass_source": engine_mass[1],
                               **compare_forces(force.t, force.force, *two_body, window_s=window).to_dict(),
                               "best_engine_mass_kg": best, "best_nrmse": best_nrmse}
    return doc
