"""Residual analysis: where a fit's residuals stop looking like measurement noise.

For each fitted channel the residual (measured - model) divided by its sigma should be
white noise of unit variance. Two checks, both per channel:

- whiteness: the Ljung-Box statistic Q = n (n + 2) sum_k rho_k^2 / (n - k) over the first
  ``lags`` autocorrelations, chi-square with ``lags`` degrees of freedom under white noise
  (p-value reported);
- windows: the residual averaged over a sliding window of ``window_ms`` (the shape of a
  missing force, which lasts tens of ms, survives the average; noise does not). Where the
  average passes ``threshold`` times its standard deviation under noise, a window of
  systematic misfit starts; it ends where the average falls back. The noise level of the
  average is the larger of: what white noise of the residual's fast part (what the
  sliding mean removes, with that part's autocorrelation time) would give, and the
  average's robust spread (1.4826 MAD) over the whole record, so that correlated tracking
  errors, which make the average wander everywhere, do not raise alarms.

Each window is placed in time (ms after first contact), in the phase of the crash
(approach, compression, restitution, after separation, from the fitted model) and in
crush depth (m, the fitted model's crush over the window).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy import stats

from video.filters import integrated_autocorrelation_time

PHASES = ("approach", "compression", "restitution", "after separation")
#: Ljung-Box p-value below which a channel's residuals are said not to be white noise.
WHITE_P = 1e-3


@dataclasses.dataclass(frozen=True)
class Window:
    """A span of systematic misfit in one channel.

    channel : channel name; start_ms, end_ms : ms after first contact (measurement clock);
    peak_sigma : the sliding mean's largest |value| over its noise level; sign : +1 when
    the model lies below the measurement (measured - model > 0); phase : phase at the
    window's peak; crush_m : (min, max) model crush over the window, m.
    """

    channel: str
    start_ms: float
    end_ms: float
    peak_sigma: float
    sign: int
    phase: str
    crush_m: tuple[float, float]

    def as_dict(self) -> dict:
        return {"channel": self.channel, "window_ms": [self.start_ms, self.end_ms],
                "peak_sigma": self.peak_sigma, "sign": self.sign, "phase": self.phase,
                "crush_m": list(self.crush_m)}


@dataclasses.dataclass(frozen=True)
class ChannelAnalysis:
    """Residual statistics of one channel: rms (channel unit), chi2 (sum of squared
    normalised residuals), n samples, ljung_box_p, tau (autocorrelation time of the
    fast part), windows, and tau_noise: the noise's effective autocorrelation time, tau
    times the factor by which the sliding mean's robust spread exceeds what white noise
    would give (squared): correlated tracking errors that wander slowly raise it, a local
    misfit does not."""

    channel: str
    rms: float
    chi2: float
    n: int
    ljung_box_p: float
    tau: float
    windows: tuple[Window, ...]
    tau_noise: float = 1.0

    @property
    def white(self) -> bool:
        return not self.windows


@dataclasses.dataclass(frozen=True)
class ResidualAnalysis:
    channels: dict[str, ChannelAnalysis]
    phases_ms: dict[str, float | None]

    @property
    def white(self) -> bool:
        """No channel has a window of systematic misfit."""
        return all(c.white for c in self.channels.values())

    def correlated_channels(self, p_value: float = WHITE_P) -> list[str]:
        """Channels whose residuals the Ljung-Box test finds not white (p below ``p_value``),
        windows or not."""
        return [name for name, c in self.channels.items() if c.ljung_box_p < p_value]

    @property
    def windows(self) -> list[Window]:
        """All windows, strongest first."""
        out = [w for c in self.channels.values() for w in c.windows]
        return sorted(out, key=lambda w: -w.peak_sigma)


def phase_times_ms(fr) -> dict[str, float | None]:
    """Phase boundaries of the fitted model on the measurement's clock (ms): the end of
    compression (the car stops, vx <= 0) and the separation from the barrier."""
    from sim import events_ms

    tr = fr.trajectory
    t = np.asarray(tr.t)
    stopped = np.flatnonzero(np.asarray(tr.vx) <= 0.0)
    shift = fr.contact_time * 1e3
    comp = float(t[stopped[0]] * 1e3) + shift if len(stopped) else None
    sep = events_ms(tr).get("separation")
    return {"compression_end": comp, "separation": None if sep is None else sep + shift}


def phase_at(t_ms: float, phases: dict) -> str:
    """The crash phase at ``t_ms`` (ms after first contact)."""
    if t_ms < 0:
        return PHASES[0]
    comp, sep = phases.get("compression_end"), phases.get("separation")
    if comp is None or t_ms <= comp:
        return PHASES[1]
    if sep is None or t_ms <= sep:
        return PHASES[2]
    return PHASES[3]


def model_crush(fr, t_s: np.ndarray) -> np.ndarray:
    """m, the fitted model's crush at measurement times ``t_s`` (s)."""
    tr = fr.trajectory
    return np.interp(np.asarray(t_s) - fr.contact_time, np.asarray(tr.t), np.asarray(tr.crush), left=0.0)


def normalised_residuals(fr, channel: str):
    """(t (s), (measured - model) / sigma) over the channel's valid samples."""
    m = fr.measurement
    valid = m.valid(channel)
    y = np.asarray(m.channels[channel])[valid]
    pred = np.asarray(fr.predictions[channel])[valid]
    return np.asarray(m.t)[valid], (y - pred) / np.asarray(m.sigma[channel])[valid]


def ljung_box_p(z: np.ndarray, lags: int = 20) -> float:
    """p-value of the Ljung-Box test that ``z`` is white."""
    z = np.asarray(z, float) - np.mean(z)
    n = len(z)
    lags = min(lags, n // 4)
    var = float(z @ z)
    if lags < 1 or var <= 0:
        return 1.0
    rho = np.array([float(z[:-k] @ z[k:]) / var for k in range(1, lags + 1)])
    q = n * (n + 2) * np.sum(rho**2 / (n - np.arange(1, lags + 1)))
    return float(stats.chi2.sf(q, lags))


def sliding_mean(z: np.ndarray, width: int) -> np.ndarray:
    """Centred moving average over ``width`` samples (shorter at the ends)."""
    kernel = np.ones(width)
    num = np.convolve(z, kernel, mode="same")
    den = np.convolve(np.ones_like(z), kernel, mode="same")
    return num / den


def analyse(fr, channels=None, window_ms: float = 15.0, threshold: float = 5.0, lags: int = 20) -> ResidualAnalysis:
    """Residual analysis of a FitResult (see module doc).

    Parameters
    ----------
    fr : identify.fitting.collision_fit.FitResult.
    channels : channels to analyse (default: every fitted channel).
    window_ms : ms, width of the sliding mean.
    threshold : alarm level of the sliding mean, in its noise standard deviations.
    lags : autocorrelation lags of the Ljung-Box test.
    """
    m = fr.measurement
    phases = phase_times_ms(fr)
    names = channels or [c for c in fr.predictions if c in m.channels and c not in m.derived]
    out = {}
    for name in names:
        t, z = normalised_residuals(fr, name)
        if len(z) < 20:
            continue
        dt_ms = float(np.median(np.diff(t))) * 1e3
        width = max(3, int(round(window_ms / dt_ms)) | 1)
        smooth = sliding_mean(z, width)
        fast = z - smooth
        tau = integrated_autocorrelation_time(fast)
        white = float(np.std(fast)) / math.sqrt(1.0 - 1.0 / width) * math.sqrt(tau / width)
        # correlated tracking errors make the sliding mean wander more than white noise
        # would: its robust spread over the whole record (a misfit is local) bounds it
        robust = 1.4826 * float(np.median(np.abs(smooth - np.median(smooth))))
        noise = max(white, robust)
        score = smooth / max(noise, 1e-12)
        windows = []
        above = np.abs(score) > threshold
        edges = np.flatnonzero(np.diff(np.concatenate([[0], above.astype(int), [0]])))
        for a, b in zip(edges[::2], edges[1::2]):
            # widen to where the mean falls back to a third of the alarm level
            while a > 0 and abs(score[a - 1]) > threshold / 3 and np.sign(score[a - 1]) == np.sign(score[a]):
                a -= 1
            while b < len(z) and abs(score[b]) > threshold / 3 and np.sign(score[b]) == np.sign(score[b - 1]):
                b += 1
            seg = slice(a, b)
            k = a + int(np.argmax(np.abs(score[seg])))
            crush = model_crush(fr, t[seg])
            windows.append(Window(name, round(float(t[a]) * 1e3, 1), round(float(t[b - 1]) * 1e3, 1),
                                  round(float(abs(score[k])), 1), int(np.sign(score[k])),
                                  phase_at(float(t[k]) * 1e3, phases),
                                  (round(float(crush.min()), 3), round(float(crush.max()), 3))))
        merged = _merge(windows)
        rms = float(np.sqrt(np.mean((z * np.asarray(m.sigma[name])[m.valid(name)]) ** 2)))
        tau_noise = max(1.0, tau * (noise / max(white, 1e-12)) ** 2)
        out[name] = ChannelAnalysis(name, rms, float(z @ z), len(z), ljung_box_p(z, lags), tau, tuple(merged),
                                    tau_noise)
    return ResidualAnalysis(out, phases)


def _merge(windows: list[Window]) -> list[Window]:
    """Merge overlapping windows of one channel (widening can make them overlap)."""
    out: list[Window] = []
    for w in sorted(windows, key=lambda w: w.start_ms):
        if out and w.start_ms <= out[-1].end_ms:
            prev = out[-1]
            strong = prev if prev.peak_sigma >= w.peak_sigma else w
            out[-1] = dataclasses.replace(
                strong, start_ms=prev.start_ms, end_ms=max(prev.end_ms, w.end_ms),
                crush_m=(min(prev.crush_m[0], w.crush_m[0]), max(prev.crush_m[1], w.crush_m[1])))
        else:
            out.append(w)
    return out


def channel_chi2(fr, tau: dict | None = None) -> dict[str, float]:
    """channel -> sum of squared normalised residuals, divided by ``tau[channel]`` when
    given (n correlated samples carry the information of n / tau independent ones)."""
    out = {}
    for name in fr.predictions:
        m = fr.measurement
        if name not in m.channels or name in m.derived:
            continue
        _, z = normalised_residuals(fr, name)
        out[name] = float(z @ z) / (tau or {}).get(name, 1.0)
    return out
