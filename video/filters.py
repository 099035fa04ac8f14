"""SAE J211-1 / ISO 6487 channel-frequency-class (CFC) filters, and the correlation time of a
series' errors (:func:`integrated_autocorrelation_time`).

J211's digital filter (its Appendix C) is a 2-pole Butterworth low-pass run forward and
then backward over the data, which makes a 4-pole filter with zero phase:

    wd = 2 pi CFC 2.0775            (rad/s)
    wa = tan(wd T / 2)              (T = 1 / sample rate)
    a0 = wa^2 / (1 + sqrt(2) wa + wa^2),  a1 = 2 a0,  a2 = a0
    b1 = -2 (wa^2 - 1) / (1 + sqrt(2) wa + wa^2)
    b2 = (-1 + sqrt(2) wa - wa^2) / (1 + sqrt(2) wa + wa^2)
    Y[t] = a0 X[t] + a1 X[t-1] + a2 X[t-2] + b1 Y[t-1] + b2 Y[t-2]

Its gain is -3 dB at 5/3 of the class number (CFC 60: 100 Hz, CFC 180: 300 Hz,
CFC 600: 1000 Hz, CFC 1000: 1650 Hz) when the sample rate is high against the class; the
bilinear transform moves the -3 dB point up as the corner nears the Nyquist rate (CFC 60
at 1000 Hz: 101.7 Hz; CFC 180 at 1000 Hz: 346 Hz, so J211's advice of a sample rate of at
least ten times the class matters). The ends are padded by point reflection (an odd
extension) so that the start-up transients fall outside the data. Film displacement
sampled at 1000 fps allows CFC 60 and 180 (the corner must stay below the Nyquist rate).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter

from video.errors import VideoError

__all__ = ["CFC_CLASSES", "Filtered", "j211_coefficients", "cfc_filter", "velocity",
           "frequency_response"]

CFC_CLASSES = (60, 180, 600, 1000)


@dataclass(frozen=True)
class Filtered:
    """A filtered channel.

    Attributes
    ----------
    values : (n,) float64
        Filtered samples (NaN where the input was NaN).
    sigma : (n,) float64
        One-standard-deviation uncertainty per sample, propagated from the input's
        sigma through the filter (independent input errors assumed).
    cfc : int
        The channel frequency class used.
    fs : float
        Sample rate, Hz.
    quantity : str
        What ``values`` is: ``"displacement"``, ``"velocity"``, ...
    """

    values: np.ndarray
    sigma: np.ndarray
    cfc: int
    fs: float
    quantity: str


def j211_coefficients(cfc: int, fs: float) -> tuple[np.ndarray, np.ndarray]:
    """Coefficients of J211's 2-pole pass in ``scipy.signal.lfilter`` form.

    Parameters
    ----------
    cfc : int
        One of 60, 180, 600, 1000.
    fs : float
        Sample rate, Hz.

    Returns
    -------
    b : (3,) float64
        ``[a0, a1, a2]`` of J211 (numerator).
    a : (3,) float64
        ``[1, -b1, -b2]`` (J211's feedback terms with lfilter's sign).
    """
    if cfc not in CFC_CLASSES:
        raise VideoError(f"unknown filter class CFC {cfc}; use one of {CFC_CLASSES}")
    if not fs > 0:
        raise VideoError(f"sample rate must be positive, got {fs} Hz")
    wd = 2.0 * np.pi * cfc * 2.0775
    half = wd / (2.0 * fs)
    if half >= 0.45 * np.pi:
        lowest = int(np.ceil(2.0 * cfc * 2.0775 / 0.9))
        raise VideoError(
            f"CFC {cfc} needs a sample rate above {lowest} Hz, the data has {fs:g} Hz; "
            f"use a lower class (CFC 60 or 180 for 1000 fps film)")
    wa = np.tan(half)
    s2 = np.sqrt(2.0)
    den = 1.0 + s2 * wa + wa * wa
    a0 = wa * wa / den
    b1 = -2.0 * (wa * wa - 1.0) / den
    b2 = (-1.0 + s2 * wa - wa * wa) / den
    return np.array([a0, 2 * a0, a0]), np.array([1.0, -b1, -b2])


def frequency_response(cfc: int, fs: float, freqs_hz: np.ndarray) -> np.ndarray:
    """Gain of the complete (forward + backward) filter at ``freqs_hz``.

    Returns
    -------
    (F,) float64
        ``|H(f)|^2`` of the 2-pole pass, i.e. the zero-phase 4-pole gain (dimensionless).
    """
    b, a = j211_coefficients(cfc, fs)
    z = np.exp(-1j * 2 * np.pi * np.asarray(freqs_hz, dtype=float) / fs)
    h = (b[0] + b[1] * z + b[2] * z * z) / (a[0] + a[1] * z + a[2] * z * z)
    return np.abs(h) ** 2


def _pad_len(cfc: int, fs: float) -> int:
    """Samples of padding: several time constants of the 2-pole pass."""
    return int(np.ceil(3.0 * fs / (cfc * 2.0775))) + 6


def _filtfilt(x: np.ndarray, b: np.ndarray, a: np.ndarray, pad: int) -> np.ndarray:
    """J211 forward-backward pass over one finite run, ends padded by point reflection."""
    n = len(x)
    p = min(pad, n - 1)
    if p > 0:
        head = 2 * x[0] - x[p:0:-1]
        tail = 2 * x[-1] - x[-2:-p - 2:-1]
        ext = np.concatenate([head, x, tail])
    else:
        ext = x.copy()
    # start each pass at rest on its first value (no step at the start)
    zi = _steady_state(b, a) * ext[0]
    y, _ = lfilter(b, a, ext, zi=zi)
    y = y[::-1]
    zi = _steady_state(b, a) * y[0]
    y, _ = lfilter(b, a, y, zi=zi)
    y = y[::-1]
    return y[p: p + n]


def _steady_state(b: np.ndarray, a: np.ndarray) -> np.ndarray:
    from scipy.signal import lfilter_zi

    return lfilter_zi(b, a)


def _kernel(cfc: int, fs: float, derivative: bool) -> np.ndarray:
    """Effective impulse response of the whole chain (for the propagation of sigma)."""
    b, a = j211_coefficients(cfc, fs)
    m = _pad_len(cfc, fs) * 4
    imp = np.zeros(2 * m + 1)
    imp[m] = 1.0
    y = lfilter(b, a, imp)
    y = lfilter(b, a, y[::-1])[::-1]
    if derivative:
        y = np.gradient(y) * fs
    return y


def _runs(ok: np.ndarray) -> list[tuple[int, int]]:
    """(start, stop) of the runs of True in a boolean array."""
    d = np.diff(np.concatenate([[0], ok.astype(np.int8), [0]]))
    return list(zip(np.nonzero(d == 1)[0], np.nonzero(d == -1)[0]))


def _apply(x, sigma, fs, cfc, derivative):
    x = np.asarray(x, dtype=float)
    if x.ndim != 1:
        raise VideoError(f"a channel to filter must be 1-D, got shape {x.shape}")
    b, a = j211_coefficients(cfc, fs)
    sig = np.zeros_like(x) if sigma is None else np.broadcast_to(
        np.asarray(sigma, dtype=float), x.shape)
    out = np.full_like(x, np.nan)
    out_sig = np.full_like(x, np.nan)
    ker2 = _kernel(cfc, fs, derivative) ** 2
    pad = _pad_len(cfc, fs)
    for s, e in _runs(np.isfinite(x)):
        if e - s < 3:
            continue
        y = _filtfilt(x[s:e], b, a, pad)
        if derivative:
            y = np.gradient(y) * fs
        out[s:e] = y
        full = np.convolve(np.nan_to_num(sig[s:e]) ** 2, ker2)
        off = (len(ker2) - 1) // 2
        var = full[off: off + (e - s)]
        out_sig[s:e] = np.sqrt(var)
    return out, out_sig


def cfc_filter(x: np.ndarray, fs: float, cfc: int = 180,
               sigma: np.ndarray | None = None) -> Filtered:
    """Filter a channel with SAE J211 class ``cfc``.

    Parameters
    ----------
    x : (n,) float
        Samples (any unit); NaN gaps split the channel into runs filtered separately.
    fs : float
        Sample rate, Hz.
    cfc : int
        60, 180, 600 or 1000.
    sigma : (n,) float, optional
        One-sigma uncertainty of each input sample, same unit as ``x``.

    Returns
    -------
    Filtered
        ``quantity="filtered"``, ``cfc`` the class used.
    """
    v, s = _apply(x, sigma, fs, cfc, derivative=False)
    return Filtered(values=v, sigma=s, cfc=cfc, fs=float(fs), quantity="filtered")


def velocity(x_m: np.ndarray, fs: float, cfc: int = 180,
             sigma_m: np.ndarray | None = None) -> Filtered:
    """Velocity from sampled displacement: J211 filter of class ``cfc``, then central
    differences.

    Parameters
    ----------
    x_m : (n,) float
        Displacement, m.
    fs : float
        Sample rate, Hz (frames per second).
    cfc : int
        Filter class (60 or 180 for 1000 fps film).
    sigma_m : (n,) float, optional
        Displacement uncertainty per sample, m.

    Returns
    -------
    Filtered
        ``values`` in m/s, ``sigma`` in m/s, ``quantity="velocity"``.
    """
    v, s = _apply(x_m, sigma_m, fs, cfc, derivative=True)
    return Filtered(values=v, sigma=s, cfc=cfc, fs=float(fs), quantity="velocity")


def integrated_autocorrelation_time(residual: np.ndarray, max_lag: int = 50) -> float:
    """tau = 1 + 2 * sum of the residual's autocorrelations, summed over lags while the
    sums of neighbouring pairs stay positive (Geyer's initial positive sequence); 1 for
    white noise, larger when neighbouring samples' errors are alike (an AR(1) process of
    coefficient phi has tau = (1 + phi) / (1 - phi)). Never below 1. n correlated samples
    carry the information of n / tau independent ones: a chi-square summed over them is
    divided by it (the fit's channels, a camera's turn told from its shift)."""
    r = np.asarray(residual, float)
    r = r - r.mean()
    n, var = len(r), float(r @ r)
    if n < 10 or var <= 0:
        return 1.0
    rho = [float(r[:-k] @ r[k:]) / var for k in range(1, min(max_lag, n // 4) + 1)]
    total = 0.0
    for k in range(0, len(rho) - 1, 2):
        pair = rho[k] + rho[k + 1]
        if pair <= 0:
            break
        total += pair
    return max(1.0, 1.0 + 2.0 * total)
