"""Wheels that spin on: a film's hub angle running ahead of the car's travel.

A real wheel has spin inertia and grips the floor through friction only: when the car
decelerates at 30 g, its wheels cannot follow and turn on, slipping (on a reference-world
film the rear wheel turned 2 rad beyond the car's travel and was still turning forwards
100 ms after the car had started back). The model's wheels spin too (``sim.wheels``), but
its grip is one coefficient, not a tyre's slip curve, and how far a slipping wheel runs
ahead is that curve's detail: fitted, those samples drag the parameters towards it (before
the model had the spin, the fit did not converge at all on such a film; with it, on
development film 960001, the film's scale ran to its bound and the speed 5 % off). So a
wheel channel is fitted only until its angle runs ahead of rolling (by ``SPIN_ON_RAD`` and 3
of its sigmas); what follows is left out with a note (``Measurement.fitted_until_ms``).
Falling behind (a wheel that stops: blocking) is what the front-wheel-block candidate looks
for, and is kept.
"""

from __future__ import annotations

import dataclasses

import numpy as np

WHEEL_CHANNELS = ("front_wheel_angle_rad", "rear_wheel_angle_rad")
SPIN_ON_RAD = 0.1  # rad: 30 mm of tread on a 0.3 m wheel, beyond the pitch's share of an axle's travel
ONSET_SHARE = 0.3  # the left-out span starts where the lead first passed this share of the threshold


def lead_over_rolling(t, angle, x, wheel_radius: float):
    """(n,) rad: how far a wheel's ``angle`` has turned beyond rolling with the car's
    displacement ``x`` (m), angle - x / wheel_radius less its median before contact (t < 0,
    s); NaN where either is. None with fewer than 3 samples before contact."""
    t, angle, x = (np.asarray(a, float) for a in (t, angle, x))
    lead = angle - x / wheel_radius
    before = np.isfinite(lead) & (t < 0.0)
    return lead - np.median(lead[before]) if before.sum() >= 3 else None


def spin_on_time(t, angle, sigma, x, x_sigma, wheel_radius: float) -> float | None:
    """Time (s, the measurement's clock) from which a wheel's ``angle`` (rad, one-sigma
    ``sigma``) runs ahead of rolling with the car's displacement ``x`` (m, ``x_sigma``), or
    None when it never does: the lead (``lead_over_rolling``) exceeds ``SPIN_ON_RAD`` and 3
    combined sigmas, and never falls back below ``ONSET_SHARE`` of that afterwards. The time
    returned is the last sample before that where the lead was still below ``ONSET_SHARE`` of
    the threshold: where the spinning on began.

    A wheel that slipped ahead and then fell back behind rolling did not spin on: friction
    brings a slipping wheel's speed back to the car's, never its angle, so the lead it had
    only shrinks when the wheel turns slower than rolling, as a wheel that the crushed
    structure blocks does (development world 960003: its front wheel led by 0.1 rad at 35
    ms, was blocked and fell 0.16 rad behind; cut from 17 ms on, the blocking went unseen)."""
    t, sigma, x_sigma = (np.asarray(a, float) for a in (t, sigma, x_sigma))
    lead = lead_over_rolling(t, angle, x, wheel_radius)
    if lead is None:
        return None
    ok = np.isfinite(lead) & np.isfinite(sigma) & np.isfinite(x_sigma)
    threshold = np.maximum(SPIN_ON_RAD, 3.0 * np.hypot(sigma, x_sigma / wheel_radius))
    ahead = ok & (t >= 0.0) & (lead > threshold)
    fallen_back = ok & (lead < ONSET_SHARE * threshold)
    # samples from which on the lead never falls back (a cumulative "any" from the end)
    stays = ~np.flip(np.cumsum(np.flip(fallen_back)) > 0)
    sustained = np.flatnonzero(ahead & stays)
    if len(sustained) == 0:
        return None
    first = sustained[0]
    calm = np.flatnonzero(fallen_back[:first])
    return float(t[calm[-1]]) if len(calm) else float(t[first])


def without_spinning_wheels(measurement, wheel_radius: float):
    """``measurement`` with each wheel channel's samples after its spin-on time left out
    (sigma NaN: not fitted; the samples stay in the measurement) and a note per wheel;
    unchanged without a wheel channel, without a measured x, or when no wheel runs ahead."""
    m = measurement
    if not m.measures_position:
        return m
    sigma, notes, until = dict(m.sigma), list(m.notes), dict(m.fitted_until_ms)
    changed = False
    for name in WHEEL_CHANNELS:
        if name not in m.channels:
            continue
        x, x_sigma = m.channels["x_m"], m.sigma["x_m"]
        onset = spin_on_time(m.t, m.channels[name], m.sigma[name], x, x_sigma, wheel_radius)
        if onset is None:
            continue
        cut = m.t > onset
        lead = np.nanmax(np.where(cut & np.isfinite(m.sigma[name]),
                                  lead_over_rolling(m.t, m.channels[name], x, wheel_radius), np.nan))
        sigma[name] = np.where(cut, np.nan, m.sigma[name])
        until[name] = onset * 1e3
        changed = True
        wheel = name.split("_")[0]
        notes.append(f"the {wheel} wheel turns on ahead of the car's travel from {onset * 1e3:.1f} ms (up to "
                     f"{lead:.2f} rad more than rolling): it spins on, slipping, as far as a tyre's slip curve lets it, "
                     f"which the model's one grip coefficient does not follow, so its angle is fitted only until then")
    if not changed:
        return m
    return dataclasses.replace(m, sigma=sigma, notes=tuple(notes), fitted_until_ms=until)
