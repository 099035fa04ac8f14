"""From a sensor recording (accelerometers, barrier load cells) to the measured motion.

The readers (``nhtsa``, ``isomme``) turn their files into a :class:`SensorTest`: channels
in SI units with this package's signs (acceleration forward positive, so a crash pulse is
negative; barrier force compressive positive). This module then

1. checks that channels that are combined share one time base (:func:`common_time_base`);
2. removes each group's zero offset (mean of the pre-impact samples, t <= -5 ms);
3. finds the time of first contact from the pulse onset (:func:`find_onset`): the summed
   barrier force when the test has load cells (it rises the instant the bumper touches),
   otherwise the vehicle's own deceleration (which lags the bumper by a few ms);
4. filters the averaged vehicle acceleration with SAE J211 CFC 180 (``video.filters``),
   integrates it to velocity (from the header's impact speed) and displacement (0 at
   contact), and puts a sigma on every sample (:func:`motion_sigma`);
5. does the same for the engine's X accelerometers when the test has them (a second
   measured body: the engine hits the barrier and is stopped long before the cabin);
6. returns an :class:`identify.recordings.measurement.Measurement` with ``x_m`` and ``vx_mps``, and
   ``engine_x_m`` and ``engine_vx_mps`` (NaN where the engine was not measured).

Engine channels that cannot be used are skipped with a note, never with an error
(:func:`usable_engine_channels`): the cabin alone still makes a Measurement.

The summed barrier force is deliberately *not* a channel of the Measurement: it is the
independent check of ``identify.report.force_check``, which the fit must not see.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from identify.errors import UserError
from identify.recordings.measurement import Measurement

G0 = 9.80665  # m/s^2, standard gravity (J211's "g")
NOISE_END_S = -0.005  # s, pre-impact samples used for offset and noise end here

__all__ = [
    "G0", "Channel", "SensorTest", "MotionOptions", "common_time_base", "combine",
    "find_onset", "onset_sigma", "contact_measurement", "contact_time", "filter_cfc", "integrate",
    "motion_sigma", "channel_motions",
    "usable_engine_channels", "measurement_from_test", "crash_facts",
]


@dataclass(frozen=True)
class Channel:
    """One recorded channel, in SI units and this package's sign convention.

    Attributes
    ----------
    code : str
        The source's id of the channel (NHTSA curve number, ISO-MME channel code).
    name : str
        Its description, for messages and reports.
    t : (n,) float64
        Sample times, s, on the recording's own time base (0 = its trigger).
    values : (n,) float64
        m/s^2 (acceleration, forward positive) or N (barrier force, compressive positive).
    quantity : str
        ``"acceleration"`` or ``"force"``.
    redundant : bool
        True for a redundant sensor at the same place as a primary one.
    """

    code: str
    name: str
    t: np.ndarray
    values: np.ndarray
    quantity: str
    redundant: bool = False

    @property
    def fs(self) -> float:
        """Sample rate, Hz."""
        return float(1.0 / np.median(np.diff(self.t)))


@dataclass(frozen=True)
class SensorTest:
    """A barrier crash test as recorded by sensors, before any processing.

    Attributes
    ----------
    source : str
        File the test was read from.
    impact_speed_mps : float
        Impact speed from the test's header, m/s.
    mass_kg : float or None
        Test mass from the header, kg.
    vehicle : tuple of Channel
        Vehicle X accelerations to average (rear-seat crossmember or CG), valid ones only.
    barrier : tuple of Channel
        Barrier load-cell X forces to sum (valid ones only); empty if none were recorded.
    title : str
        The test's title.
    notes : tuple of str
        What the reader skipped or assumed.
    engine : tuple of Channel
        Engine X accelerations to average (m/s^2, forward positive, like ``vehicle``), valid
        ones only, on the vehicle channels' clock; a channel may end before them (its
        sensor failed), the Measurement then has no engine motion after its end. Empty
        when the engine was not instrumented.
    """

    source: str
    impact_speed_mps: float
    mass_kg: float | None
    vehicle: tuple[Channel, ...]
    barrier: tuple[Channel, ...] = ()
    title: str = ""
    notes: tuple[str, ...] = ()
    engine: tuple[Channel, ...] = ()


@dataclass(frozen=True)
class MotionOptions:
    """Settings of the acceleration-to-motion stage.

    Attributes
    ----------
    cfc : int
        SAE J211 class of the vehicle accelerations (J211 and ISO 6487 prescribe CFC 180
        for accelerations to be integrated).
    rate_hz : float
        Sample rate of the Measurement, Hz (the collision model samples at 1000 Hz).
    onset_sigmas : float
        A pulse has begun when it exceeds this many standard deviations of the
        pre-impact noise (and 2 % of its own peak).
    sensitivity_rel : float
        One-sigma relative error of the accelerometers' sensitivity (calibration), 1.
    speed_sigma_mps : float
        One-sigma error of the header's impact speed (speed traps), m/s.
    sigma_floor_m, sigma_floor_mps : float
        Smallest sigma of a displacement / velocity sample, m and m/s.
    """

    cfc: int = 180
    rate_hz: float = 1000.0
    onset_sigmas: float = 5.0
    sensitivity_rel: float = 0.01
    speed_sigma_mps: float = 0.03
    sigma_floor_m: float = 1e-4
    sigma_floor_mps: float = 1e-3


def common_time_base(channels: tuple[Channel, ...], what: str) -> np.ndarray:
    """The time base that ``channels`` share, or a UserError saying which ones differ.

    Parameters
    ----------
    channels : tuple of Channel
        Channels to be averaged or summed.
    what : str
        What they are, for the message (``"vehicle accelerations"``).

    Returns
    -------
    (n,) float64
        Sample times, s.
    """
    if not channels:
        raise UserError(f"no {what} to combine")
    first = channels[0]
    for ch in channels[1:]:
        if not np.isclose(ch.fs, first.fs, rtol=1e-4):
            raise UserError(
                f"{what}: mismatched sample rates, channel {ch.code} ({ch.name}) is sampled at "
                f"{ch.fs:g} Hz and channel {first.code} ({first.name}) at {first.fs:g} Hz")
        if len(ch.t) != len(first.t) or not np.allclose(ch.t, first.t, atol=0.25 / first.fs):
            raise UserError(
                f"{what}: channel {ch.code} ({ch.name}) covers {ch.t[0]:g}..{ch.t[-1]:g} s, "
                f"channel {first.code} covers {first.t[0]:g}..{first.t[-1]:g} s; they must share "
                f"one time base")
    return np.asarray(first.t, dtype=float)


def _noise_window(t: np.ndarray, source: str) -> np.ndarray:
    pre = t <= NOISE_END_S + 1e-9  # robust to rounding of the time base
    if np.count_nonzero(pre) < 20:
        raise UserError(
            f"{source}: the recording needs pre-impact data (at least 20 samples before "
            f"t = {NOISE_END_S * 1e3:g} ms) to measure the sensors' zero offset and noise")
    return pre


def combine(channels: tuple[Channel, ...], how: str, what: str, source: str = "") -> tuple[np.ndarray, np.ndarray]:
    """Average or sum channels after removing each one's pre-impact offset.

    Parameters
    ----------
    channels : tuple of Channel
        Channels on one time base.
    how : str
        ``"mean"`` (redundant accelerometers) or ``"sum"`` (load cells).
    what, source : str
        For messages.

    Returns
    -------
    t : (n,) float64
        s.
    values : (n,) float64
        Combined values, offset-free, in the channels' unit.
    """
    t = common_time_base(channels, what)
    pre = _noise_window(t, source or what)
    stack = np.stack([np.asarray(c.values, dtype=float) for c in channels])
    stack = stack - stack[:, pre].mean(axis=1, keepdims=True)
    return t, (stack.mean(axis=0) if how == "mean" else stack.sum(axis=0))


def filter_cfc(values: np.ndarray, fs: float, cfc: int) -> np.ndarray:
    """SAE J211 / ISO 6487 CFC filter (``video.filters.cfc_filter``), errors as UserError.

    Parameters
    ----------
    values : (n,) float
        Samples, any unit.
    fs : float
        Sample rate, Hz.
    cfc : int
        60, 180, 600 or 1000.

    Returns
    -------
    (n,) float64
        Filtered samples, same unit.
    """
    from video.errors import VideoError
    from video.filters import cfc_filter

    try:
        return cfc_filter(np.asarray(values, dtype=float), fs, cfc).values
    except VideoError as err:
        raise UserError(str(err)) from None


def find_onset(t: np.ndarray, pulse: np.ndarray, sigmas: float = 5.0) -> float:
    """Time at which a pulse begins, s.

    The pulse (oriented so that it is positive) first exceeds ``max(sigmas * noise, 2 % of
    its peak)``, where noise is the standard deviation of the samples at t <= -5 ms; the
    onset is the last time before that at which it was still within two standard
    deviations of its pre-impact mean (zero), interpolated linearly between samples.

    Parameters
    ----------
    t : (n,) float
        s.
    pulse : (n,) float
        Offset-free samples, positive during the pulse (any unit).
    sigmas : float
        Threshold in standard deviations of the pre-impact noise.

    Returns
    -------
    float
        Onset time, s.
    """
    t = np.asarray(t, dtype=float)
    s = np.asarray(pulse, dtype=float)
    pre = _noise_window(t, "pulse onset")
    noise = float(np.std(s[pre]))
    level = max(sigmas * noise, 0.02 * float(np.max(s)))
    after = np.flatnonzero((s > level) & (t > NOISE_END_S))
    if len(after) == 0 or np.max(s) <= 0:
        raise UserError("no crash pulse found: the signal never rises above its pre-impact noise")
    floor = 2.0 * noise
    i = int(after[0])
    while i > 0 and s[i - 1] > floor:
        i -= 1
    if i == 0:
        return float(t[0])
    frac = (floor - s[i - 1]) / (s[i] - s[i - 1])  # s[i-1] <= floor < s[i]
    return float(t[i - 1] + frac * (t[i] - t[i - 1]))


def onset_sigma(t: np.ndarray, pulse: np.ndarray, onset: float, cfc: int) -> float:
    """One-sigma uncertainty (s) of :func:`find_onset`'s ``onset`` of a CFC-filtered ``pulse``.

    Two errors add in quadrature: the filter's zero-phase smoothing moves an onset by about
    its time constant 1 / (2 pi f_3dB) (f_3dB = 5/3 CFC Hz: 0.53 ms at CFC 180), and a pulse
    that rises slowly out of the noise is found late, by about the time it takes to climb
    from the onset to 8 noise standard deviations (exact for a force growing as the square
    of time, three times too long for a ramp). On ramps, square and cube laws (1-100 kN/ms
    at 0.2-2 kN noise, 10 kHz) the error fell within one such sigma in 73-79 % of draws and
    within two in 98 % (tests/test_recordings_contact.py)."""
    t = np.asarray(t, dtype=float)
    s = np.asarray(pulse, dtype=float)
    noise = float(np.std(s[_noise_window(t, "pulse onset")]))
    climbed = np.flatnonzero((t > onset) & (s > 8.0 * noise))
    delay = float(t[climbed[0]] - onset) if len(climbed) else float(t[-1] - onset)
    return float(np.hypot(1.0 / (2.0 * np.pi * 5.0 / 3.0 * cfc), delay))


def contact_measurement(test: SensorTest, options: MotionOptions = MotionOptions()) -> tuple[float, float | None, str]:
    """Time of first contact on the recording's time base (s), its one-sigma (s) when it is
    a measurement independent of the vehicle's motion, and how it was found.

    From the summed barrier force (CFC 180 for a sharp onset) when the test has load cells:
    a measurement the fit of the motion may use (:func:`onset_sigma`). Else from the
    averaged vehicle deceleration, which begins a few ms after the bumper touches (the
    first centimetres of crush are soft): the same accelerometers the fit sees, so no
    independent measurement (sigma None).
    """
    if test.barrier:
        t, f = combine(test.barrier, "sum", "barrier forces", test.source)
        fs = 1.0 / np.median(np.diff(t))
        pulse = filter_cfc(f, fs, 180)
        onset = find_onset(t, pulse, options.onset_sigmas)
        sigma = onset_sigma(t, pulse, onset, 180)
        return onset, sigma, (f"first contact at {onset * 1e3:.2f} +- {sigma * 1e3:.2f} ms (recording time) from the "
                              "onset of the summed barrier force")
    t, a = combine(test.vehicle, "mean", "vehicle accelerations", test.source)
    fs = 1.0 / np.median(np.diff(t))
    onset = find_onset(t, -filter_cfc(a, fs, options.cfc), options.onset_sigmas)
    return onset, None, (f"first contact at {onset * 1e3:.2f} ms (recording time) from the onset of the "
                         f"vehicle deceleration; no barrier load cells, so contact may be a few ms earlier")


def contact_time(test: SensorTest, options: MotionOptions = MotionOptions()) -> tuple[float, str]:
    """Time of first contact on the recording's time base, s, and how it was found
    (:func:`contact_measurement` without its sigma)."""
    onset, _, how = contact_measurement(test, options)
    return onset, how


def integrate(t: np.ndarray, accel: np.ndarray, t0: float, v0: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Velocity and displacement from acceleration, from t0 on (trapezoidal rule).

    Parameters
    ----------
    t : (n,) float
        s.
    accel : (n,) float
        m/s^2, forward positive.
    t0 : float
        Time of first contact, s (moved to the nearest sample).
    v0 : float
        Velocity at t0, m/s.

    Returns
    -------
    tau : (m,) float64
        Time since contact, s (0 first).
    v : (m,) float64
        Velocity, m/s.
    x : (m,) float64
        Displacement since contact, m.
    """
    i0 = int(np.argmin(np.abs(np.asarray(t) - t0)))
    tt = np.asarray(t[i0:], dtype=float)
    a = np.asarray(accel[i0:], dtype=float)
    dt = np.diff(tt)
    v = v0 + np.concatenate([[0.0], np.cumsum(0.5 * (a[1:] + a[:-1]) * dt)])
    x = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * dt)])
    return tt - tt[0], v, x


def motion_sigma(tau, v, x, v0, noise_sigma, fs, cfc, n_noise, options: MotionOptions,
                 spread_v=None, spread_x=None):
    """One-sigma uncertainty of integrated velocity and displacement, per sample.

    Independent terms added in quadrature (tau = time since contact, s):

    - zero-offset error of the accelerometers, sigma_b = noise * sqrt(tc / T), with T the
      pre-impact span and tc = 1 / (2 f3dB) the correlation time of CFC-filtered noise
      (f3dB = 5/3 CFC): sigma_v = sigma_b tau, sigma_x = sigma_b tau^2 / 2;
    - random walk of the filtered noise: sigma_v = noise sqrt(tc tau),
      sigma_x = noise sqrt(tc) tau^1.5 / sqrt(3);
    - sensitivity (calibration) error: ``sensitivity_rel`` times the integrated change,
      |v - v0| and |x - v0 tau|;
    - disagreement of the averaged channels: their standard error (``spread_v``,
      ``spread_x``), when more than one was averaged.

    The impact-speed error is not included (it is ``Measurement.impact_speed_sigma``).
    Floors ``sigma_floor_mps`` and ``sigma_floor_m`` keep every sigma positive.

    Parameters
    ----------
    tau, v, x : (m,) float
        s, m/s, m.
    v0 : float
        m/s.
    noise_sigma : float
        Standard deviation of the filtered pre-impact acceleration, m/s^2.
    fs : float
        Sample rate, Hz.
    cfc : int
        Filter class used.
    n_noise : int
        Number of pre-impact samples.
    options : MotionOptions
    spread_v, spread_x : (m,) float, optional
        Standard error of the channel mean, m/s and m.

    Returns
    -------
    sigma_v : (m,) float64
        m/s.
    sigma_x : (m,) float64
        m.
    """
    tc = 1.0 / (2.0 * (5.0 / 3.0) * cfc)
    span = n_noise / fs
    sb = noise_sigma * np.sqrt(tc / span)
    var_v = (sb * tau) ** 2 + noise_sigma ** 2 * tc * tau + (options.sensitivity_rel * (v - v0)) ** 2
    var_x = ((sb * tau ** 2 / 2) ** 2 + noise_sigma ** 2 * tc * tau ** 3 / 3
             + (options.sensitivity_rel * (x - v0 * tau)) ** 2)
    if spread_v is not None:
        var_v = var_v + spread_v ** 2
        var_x = var_x + spread_x ** 2
    return (np.maximum(np.sqrt(var_v), options.sigma_floor_mps),
            np.maximum(np.sqrt(var_x), options.sigma_floor_m))


def channel_motions(test: SensorTest, t0: float, options: MotionOptions = MotionOptions()):
    """Each vehicle accelerometer's own velocity and displacement, processed as the averaged
    motion is (offset removed, CFC ``options.cfc``, integrated from the impact speed at t0).

    Parameters
    ----------
    test : SensorTest
    t0 : float
        First contact on the recording's time base, s.
    options : MotionOptions

    Returns
    -------
    tau : (m,) float64
        Time since contact, s.
    motions : dict
        Channel code -> (velocity (m,) m/s, displacement (m,) m), in ``test.vehicle``'s order.
    """
    t = common_time_base(test.vehicle, "vehicle accelerations")
    stack = np.stack([np.asarray(c.values, dtype=float) for c in test.vehicle])
    tau, each = _each_motion(stack, t, t0, test.impact_speed_mps, options, test.source)
    return tau, {c.code: m for c, m in zip(test.vehicle, each)}


def _each_motion(stack: np.ndarray, t: np.ndarray, t0: float, v0: float, options: MotionOptions, source: str):
    """Velocity (m/s) and displacement (m) of each row of ``stack`` (accelerations, m/s^2,
    on times ``t``, s; NaN after a channel's end), each offset-free, CFC-filtered and
    integrated from ``v0`` at ``t0``. Returns (tau, [(v, x), ...])."""
    fs = float(1.0 / np.median(np.diff(t)))
    pre = _noise_window(t, source)
    out, tau = [], None
    for one in stack:
        one = filter_cfc(one - one[pre].mean(), fs, options.cfc)
        tau, vi, xi = integrate(t, one, t0, v0)
        out.append((vi, xi))
    return tau, out


def usable_engine_channels(reference_t: np.ndarray, channels, label=None) -> tuple[tuple[Channel, ...], list[str]]:
    """The engine X accelerometers that can be averaged on the vehicle channels' clock, and
    a note on each one that cannot (skipped, never an error: the cabin alone still makes a
    Measurement).

    Rules, in order: a channel must be an acceleration with at least two samples, all
    finite; sampled at the vehicle channels' rate (relative 1e-4); its first sample at
    theirs (within a quarter interval). A channel that ends before the vehicle channels
    (by more than half an interval; a sensor that failed during the crash) is skipped when
    another engine channel reaches further: only the channels reaching furthest are kept,
    as a mean whose members drop out one by one would jump where each ends. When none
    covers the vehicle channels' span, the furthest-reaching ones are kept and the engine
    is not measured after their end (``measurement_from_test`` marks it NaN and says so).

    Parameters
    ----------
    reference_t : (n,) float
        The vehicle channels' sample times, s.
    channels : sequence of Channel
        Engine X accelerations, m/s^2.
    label : callable, optional
        ``label(channel)`` for the notes; default ``channel <code> (<name>)``.

    Returns
    -------
    kept : tuple of Channel
        In ``channels``' order.
    notes : list of str
        One per skipped channel.
    """
    label = label or (lambda ch: f"channel {ch.code} ({ch.name})")
    ref = np.asarray(reference_t, dtype=float)
    dt = float(np.median(np.diff(ref)))
    notes: list[str] = []
    fit = []
    for ch in channels:
        t = np.asarray(ch.t, dtype=float)
        why = None
        if ch.quantity != "acceleration":
            why = f"it is a {ch.quantity}, not an acceleration"
        elif len(t) < 2 or len(t) != len(np.asarray(ch.values)) or not np.all(np.isfinite(ch.values)):
            why = "it needs at least two samples, all with a value"
        elif not np.isclose(ch.fs, 1.0 / dt, rtol=1e-4):
            why = f"it is sampled at {ch.fs:g} Hz, the vehicle channels at {1.0 / dt:g} Hz"
        elif abs(t[0] - ref[0]) > 0.25 * dt:
            why = (f"it starts at {t[0] * 1e3:g} ms, the vehicle channels at {ref[0] * 1e3:g} ms "
                   f"(recording time): not one clock")
        if why:
            notes.append(f"skipped engine {label(ch)}: {why}")
        else:
            fit.append(ch)
    if not fit:
        return (), notes
    furthest = min(max(float(c.t[-1]) for c in fit), float(ref[-1]))
    reaches = [bool(c.t[-1] >= furthest - 0.5 * dt) for c in fit]
    kept = tuple(c for c, r in zip(fit, reaches) if r)
    names = ", ".join(label(c) for c in kept)
    for ch, r in zip(fit, reaches):
        if not r:
            reach = ("covers the whole recording" if furthest >= ref[-1] - 0.5 * dt
                     else f"reaches {furthest * 1e3:.1f} ms")
            notes.append(f"skipped engine {label(ch)}: its data end at {ch.t[-1] * 1e3:.1f} ms (recording "
                         f"time), before the vehicle channels' {ref[-1] * 1e3:.1f} ms, and {names} {reach}")
    return kept, notes


def _vehicle_motion(test: SensorTest, t0: float, options: MotionOptions):
    """Filtered, integrated vehicle motion at the recording's rate (see measurement_from_test)."""
    t, a = combine(test.vehicle, "mean", "vehicle accelerations", test.source)
    fs = float(1.0 / np.median(np.diff(t)))
    if options.rate_hz > fs * (1 + 1e-9):
        raise UserError(f"{test.source}: cannot resample {fs:g} Hz data to {options.rate_hz:g} Hz")
    af = filter_cfc(a, fs, options.cfc)
    pre = _noise_window(t, test.source)
    noise = float(np.std(af[pre]))
    tau, v, x = integrate(t, af, t0, test.impact_speed_mps)
    spread_v = spread_x = None
    if len(test.vehicle) > 1:
        _, each = channel_motions(test, t0, options)
        spread_v, spread_x = _spread(list(each.values()))
    sv, sx = motion_sigma(tau, v, x, test.impact_speed_mps, noise, fs, options.cfc,
                          int(np.count_nonzero(pre)), options, spread_v, spread_x)
    return tau, v, x, sv, sx, fs, noise


def _spread(each):
    """Standard error of the mean of several channels' (velocity, displacement)."""
    n = len(each)
    return (np.std([vi for vi, _ in each], axis=0, ddof=1) / np.sqrt(n),
            np.std([xi for _, xi in each], axis=0, ddof=1) / np.sqrt(n))


def _engine_motion(test: SensorTest, t0: float, options: MotionOptions):
    """Filtered, integrated engine motion on the vehicle channels' clock, processed as the
    cabin's is (see measurement_from_test); NaN after the engine channels end.

    Returns
    -------
    motion : tuple or None
        (kept channels, tau (s), v (m/s), x (m), sigma_v (m/s), sigma_x (m), noise (m/s^2),
        end of the engine data (s, recording time) or None when it covers the cabin's);
        None when no engine channel can be used.
    notes : list of str
        Channels skipped, and why.
    """
    t = common_time_base(test.vehicle, "vehicle accelerations")
    kept, notes = usable_engine_channels(t, test.engine)
    early = [c for c in kept if c.t[-1] <= max(t0, NOISE_END_S)]
    if early:
        notes += [f"skipped engine channel {c.code} ({c.name}): its data end at {c.t[-1] * 1e3:.1f} ms "
                  f"(recording time), before first contact" for c in early]
        return None, notes
    if not kept:
        return None, notes
    stack = np.full((len(kept), len(t)), np.nan)
    for k, ch in enumerate(kept):
        n = min(len(ch.t), len(t))
        stack[k, :n] = np.asarray(ch.values, dtype=float)[:n]
    fs = float(1.0 / np.median(np.diff(t)))
    pre = _noise_window(t, test.source)
    a = (stack - stack[:, pre].mean(axis=1, keepdims=True)).mean(axis=0)
    af = filter_cfc(a, fs, options.cfc)
    noise = float(np.std(af[pre]))
    tau, v, x = integrate(t, af, t0, test.impact_speed_mps)
    spread_v = spread_x = None
    if len(kept) > 1:
        _, each = _each_motion(stack, t, t0, test.impact_speed_mps, options, test.source)
        spread_v, spread_x = _spread(each)
    sv, sx = motion_sigma(tau, v, x, test.impact_speed_mps, noise, fs, options.cfc,
                          int(np.count_nonzero(pre)), options, spread_v, spread_x)
    end = float(kept[0].t[-1]) if np.isnan(a[-1]) else None
    return (kept, tau, v, x, sv, sx, noise, end), notes


def _resampled(t_out: np.ndarray, tau: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``y`` (on ``tau``, s) at ``t_out`` (s), NaN after its last finite sample."""
    ok = np.isfinite(y)
    if not np.any(ok):
        return np.full(len(t_out), np.nan)
    out = np.interp(t_out, tau[ok], y[ok])
    return np.where(t_out <= tau[ok][-1] + 1e-9, out, np.nan)


def measurement_from_test(test: SensorTest, options: MotionOptions = MotionOptions()) -> Measurement:
    """The measured motion of a sensor-recorded test, ready for the fit.

    Parameters
    ----------
    test : SensorTest
        As a reader returns it.
    options : MotionOptions

    Returns
    -------
    Measurement
        ``t`` from 0 (first contact) at ``options.rate_hz``; channels ``x_m`` (displacement
        since contact, towards the barrier) and ``vx_mps``, each with a sigma;
        ``impact_speed_mps`` from the header; ``events_ms`` with ``compression_end``
        (maximum displacement) and, when the barrier was instrumented, ``separation``.
        When ``test.engine`` has a usable channel, also ``engine_x_m`` (the engine's
        displacement since the same contact time, m) and ``engine_vx_mps`` (m/s): the mean
        of the engine accelerometers processed exactly as the cabin's (pre-impact offset
        removed, CFC ``options.cfc``, integrated from the header's impact speed at the
        cabin's t0, sigma by :func:`motion_sigma`), NaN (value and sigma) after the engine
        channels end. Engine channels that cannot be used are skipped with a note.

    Examples
    --------
    >>> from identify.recordings import read_nhtsa, measurement_from_test
    >>> m = measurement_from_test(read_nhtsa("data/nhtsa-10146/v10146.EV5"))  # doctest: +SKIP
    """
    t0, t0_sigma, how = contact_measurement(test, options)
    tau, v, x, sv, sx, fs, noise = _vehicle_motion(test, t0, options)
    t_out = np.arange(0.0, tau[-1] + 0.5 / fs, 1.0 / options.rate_hz)
    t_out = t_out[t_out <= tau[-1] + 1e-12]

    def res(y):
        return np.interp(t_out, tau, y)

    events = {}
    i_max = int(np.argmax(x))
    if 0 < i_max < len(x) - 1:
        events["compression_end"] = float(tau[i_max] * 1e3)
    sep = _separation_time(test, t0)
    if sep is not None:
        events["separation"] = sep * 1e3
    codes = ", ".join(c.code for c in test.vehicle)
    notes = tuple(test.notes) + (
        how,
        f"vehicle motion from the mean of {len(test.vehicle)} X accelerometer(s) ({codes}), "
        f"CFC {options.cfc}, pre-impact noise {noise / G0:.3f} g, integrated from "
        f"{test.impact_speed_mps:.3f} m/s",
    )
    e_channels, e_sigma, e_notes = _engine_measurement(test, t0, t_out, options)
    return Measurement(
        t=t_out,
        channels={"x_m": res(x), "vx_mps": res(v), **e_channels},
        sigma={"x_m": res(sx), "vx_mps": res(sv), **e_sigma},
        impact_speed_mps=float(test.impact_speed_mps),
        impact_speed_sigma=float(options.speed_sigma_mps),
        contact_time_sigma=t0_sigma,
        source=test.source,
        events_ms=events,
        notes=notes + e_notes,
    )


def _engine_measurement(test: SensorTest, t0: float, t_out: np.ndarray, options: MotionOptions):
    """The Measurement's engine channels on ``t_out`` (s since contact): ``engine_x_m`` (m)
    and ``engine_vx_mps`` (m/s), their sigmas and the notes; empty without a usable engine
    channel (then the notes say why, if there were any)."""
    if not test.engine:
        return {}, {}, ()
    engine, notes = _engine_motion(test, t0, options)
    if engine is None:
        return {}, {}, tuple(notes)
    kept, tau, v, x, sv, sx, noise, end = engine
    channels = {"engine_x_m": _resampled(t_out, tau, x), "engine_vx_mps": _resampled(t_out, tau, v)}
    sigma = {"engine_x_m": _resampled(t_out, tau, sx), "engine_vx_mps": _resampled(t_out, tau, sv)}
    codes = ", ".join(c.code for c in kept)
    notes.append(f"engine motion from the mean of {len(kept)} engine X accelerometer(s) ({codes}), CFC "
                 f"{options.cfc}, pre-impact noise {noise / G0:.3f} g, integrated from "
                 f"{test.impact_speed_mps:.3f} m/s at the cabin's contact time")
    if end is not None:
        notes.append(f"the engine is not measured from {(end - t0) * 1e3:.1f} ms after contact on: its "
                     f"accelerometer(s) ({codes}) end at {end * 1e3:.1f} ms recording time; engine_x_m "
                     f"and engine_vx_mps are NaN from there")
    return channels, sigma, tuple(notes)


def _separation_time(test: SensorTest, t0: float) -> float | None:
    """End of contact, s after first contact: the summed barrier force (CFC 60) falls for
    good below 2 % of its peak. None without load cells."""
    if not test.barrier:
        return None
    t, f = combine(test.barrier, "sum", "barrier forces", test.source)
    ff = filter_cfc(f, 1.0 / np.median(np.diff(t)), 60)
    above = np.flatnonzero(ff > 0.02 * ff.max())
    return float(t[above[-1]] - t0) if len(above) else None


def crash_facts(m: Measurement, separation_ms: float | None = None) -> dict[str, float]:
    """Summary numbers of a measured barrier test.

    Parameters
    ----------
    m : Measurement
        With ``x_m`` and ``vx_mps``.
    separation_ms : float, optional
        End of contact, ms; default ``m.events_ms["separation"]``, else the time of the
        largest rebound speed.

    Returns
    -------
    dict
        ``max_crush_m`` (largest displacement since contact, m), ``max_crush_ms`` (its
        time), ``separation_ms``, ``rebound_mps`` (mean backward speed from separation to
        the end of the recording, m/s, positive), ``delta_v_mps`` (impact speed plus
        rebound speed).
    """
    x = np.asarray(m.channels["x_m"])
    v = np.asarray(m.channels["vx_mps"])
    i = int(np.argmax(x))
    if separation_ms is None:
        separation_ms = m.events_ms.get("separation")
    if separation_ms is None:
        separation_ms = float(m.t[int(np.argmin(v))] * 1e3)
    after = m.t * 1e3 >= separation_ms
    if not np.any(after):
        raise UserError(f"{m.source}: the recording ends before the car leaves the barrier")
    rebound = float(-np.mean(v[after]))
    v0 = m.impact_speed_mps if m.impact_speed_mps is not None else float(v[0])
    return {"max_crush_m": float(x[i]), "max_crush_ms": float(m.t[i] * 1e3),
            "separation_ms": float(separation_ms), "rebound_mps": rebound,
            "delta_v_mps": float(v0 + rebound)}
