"""The fit's weighted least-squares pieces that do not depend on the crash model: a
channel's residual rows, the residuals' correlation time, each channel's misfit, and the
parameters' covariance.

Pure functions over arrays; ``identify.fitting.collision_fit`` puts the model in front of them. Kept
apart so that each can be checked against an independent reference (a linear problem's
textbook covariance, a Monte Carlo coverage, an AR(1) process's known correlation time)
without running a simulation (``tests/test_least_squares.py``).
"""

from __future__ import annotations

import dataclasses
import math

import jax.numpy as jnp
import numpy as np

from video.filters import integrated_autocorrelation_time


def weighted_offset(diff, w):
    """The constant c that minimises sum(w^2 (diff - c)^2): the w^2-weighted mean of diff
    (0 where every weight is 0). Channels whose zero is arbitrary (a height, an angle) are
    compared after removing it."""
    ww = w * w
    return jnp.sum(ww * diff) / jnp.maximum(jnp.sum(ww), 1e-300)


def channel_residuals(pred, y, w, offset_free: bool):
    """Weighted residual rows of one channel: w * (pred - y), with the weighted offset
    removed first when the channel's zero is arbitrary (``offset_free``). w = 1/sigma
    (1/unit of the channel), 0 where the sample is missing."""
    diff = pred - y
    if offset_free:
        diff = diff - weighted_offset(diff, w)
    return w * diff


def prior_residuals(values, mu, w):
    """Residual rows of priors: (value - mu) / sigma, given as w = 1/sigma (0: no prior)."""
    return (values - mu) * w


def channel_variance_factors(r, channel_rows: dict, n_params: int, tau_at_least: dict | None = None) -> tuple[dict, dict]:
    """Per channel, how much larger than its stated noise the residuals' variance is.

    r : (m,) weighted residual rows (model - measured) / sigma; channel_rows : channel ->
    indices of its valid rows in r; n_params : fitted parameters. Returns (tau, misfit),
    channel -> value: tau the residuals' correlation time (samples,
    :func:`integrated_autocorrelation_time`), misfit = max(1, chi2_c / dof_c), the channel's
    reduced chi-square (dof_c = n_c (n - p) / n: the parameters' degrees of freedom shared
    out in proportion to the rows). Their product is the factor by which the channel's
    variance is widened: its rows weigh as n_c / tau_c independent samples of noise as large
    as its misfit. A channel the model misses by far more than the tracker's noise (the heave
    and pitch of a car the model simplifies) then no longer lends its misfit to the others.
    ``tau_at_least``: group -> another group whose tau is a floor for its own (a short
    group's estimate is biased low: 20 samples of noise correlated over 19 gave 1.8)."""
    r = np.asarray(r, dtype=float)
    n_data = sum(len(rows) for rows in channel_rows.values())
    share = max(n_data - n_params, 1) / max(n_data, 1)
    tau, misfit = {}, {}
    for name, rows in channel_rows.items():
        z = r[rows]
        tau[name] = integrated_autocorrelation_time(z)
        misfit[name] = max(1.0, float(z @ z) / max(len(rows) * share, 1e-300)) if len(rows) else 1.0
    for name, other in (tau_at_least or {}).items():
        if name in tau and other in tau:
            tau[name] = max(tau[name], tau[other])
    return tau, misfit


@dataclasses.dataclass
class Uncertainty:
    """Covariance of fitted parameters (physical units) and what it was made from.

    cov, std, corr : covariance (unit_i unit_j), standard deviations, correlations.
    chi2 : sum of squared residual rows; dof : residual count - fitted parameters.
    tau : channel -> residual correlation time (samples); misfit : channel -> the factor
        its variance was widened by for a misfit larger than its stated noise: max(1, the
        channel's reduced chi-square) (:func:`channel_variance_factors`), or, widened as a
        whole, every channel's and prior's ``scale``.
    scale : max(1, chi2/dof) when the whole fit was widened by it (priors included), else 1.
    """

    cov: np.ndarray
    std: np.ndarray
    corr: np.ndarray
    chi2: float
    dof: int
    tau: dict
    misfit: dict
    scale: float = 1.0


def parameter_covariance(r, jac_u, dvalue_du, typical, channel_rows: dict, n_res: int,
                         per_channel: bool = True, tau_at_least: dict | None = None) -> Uncertainty:
    """Covariance of the fitted parameters at a least-squares optimum.

    r : (m,) residual rows at the optimum, weighted by the recording's own sigmas; jac_u :
    (m, p) their Jacobian with respect to the unconstrained parameters u; dvalue_du : (p,)
    derivative of each physical value with respect to its u (positive: the transforms are
    increasing); typical : (p,) each parameter's typical magnitude (physical units);
    channel_rows : channel -> indices of its valid rows in r (rows of no channel, the priors,
    are independent measurements taken at their stated sigma); n_res : number of residuals
    that carry information (valid samples and priors); per_channel : False widens the whole
    covariance by one factor instead, max(1, chi2/dof), the priors' rows included (what the
    fit did before per-channel misfits: wider where one channel misses far beyond its noise,
    which discovery's rules were set against, ``identify.discover.loop.CANDIDATE_FIT``);
    tau_at_least : as :func:`channel_variance_factors`'s.

    Gauss-Newton: cov = (J^T J)^-1 with J the Jacobian in physical units (J_u divided by
    dvalue/du, the chain rule), each channel's rows divided by sqrt(tau_c misfit_c)
    (:func:`channel_variance_factors`): n correlated samples weigh as n / tau independent
    ones, and a channel's misfit beyond its noise widens that channel alone. A measured
    prior (the contact seen in the film) keeps its own sigma, whatever another channel's
    misfit. The inversion runs on columns scaled to ``typical`` (well conditioned), and an
    eigenvalue near 0 (a direction the data do not constrain) is floored, giving that
    direction a huge variance, not the zero a pseudo-inverse would give it.
    """
    r, jac_u, dvalue_du, typical = (np.asarray(a, dtype=float) for a in (r, jac_u, dvalue_du, typical))
    chi2 = float(r @ r)
    dof = max(int(n_res) - len(typical), 1)
    tau, misfit = channel_variance_factors(r, channel_rows, len(typical), tau_at_least)
    scale = 1.0
    if not per_channel:
        scale = max(1.0, chi2 / dof)
        misfit = {name: scale for name in channel_rows}
    row_weight = np.full(len(r), 1.0 / math.sqrt(scale))
    for name, rows in channel_rows.items():
        row_weight[rows] = 1.0 / math.sqrt(tau[name] * misfit[name])
    jac_s = row_weight[:, None] * jac_u / np.maximum(dvalue_du, 1e-300)[None, :] * typical[None, :]
    eigval, eigvec = np.linalg.eigh(jac_s.T @ jac_s)
    eigval = np.maximum(eigval, 1e-14 * max(float(eigval.max()), 1e-300))
    cov = (eigvec / eigval) @ eigvec.T * np.outer(typical, typical)
    std = np.sqrt(np.diag(cov))  # > 0: every eigenvalue was floored above 0
    corr = cov / np.outer(std, std)
    return Uncertainty(cov=cov, std=std, corr=corr, chi2=chi2, dof=dof, tau=tau, misfit=misfit, scale=scale)


def held_at_measurement(unc: Uncertainty, index, sigma=None, covariance=None) -> Uncertainty:
    """The uncertainty of a fit that held parameters ``index`` (one index or several) at
    measured values of standard deviations ``sigma`` (their units; independent errors), or
    of ``covariance`` (h, h) when their errors are tied (a film's speed measured in its own
    lengths, and its scale), instead of fitting them, from ``unc``: the covariance with them
    fitted by the residuals alone (their columns in the Jacobian, no prior rows for them),
    taken at the held fit's optimum.

    The others were fitted at the held values: their covariance is the conditional one,
    C_oo - C_oh C_hh^-1 C_ho, plus the held values' own errors carried through their optimum's
    dependence on them, G S G^T with G = C_oh C_hh^-1 (the others' shift per unit of each held
    value) and S the held values' covariance. Each held parameter keeps its sigma; its
    covariance with the others is G S. One degree of freedom more than ``unc`` per parameter
    held."""
    idx = np.atleast_1d(np.asarray(index, dtype=int))
    if covariance is None:
        s = np.diag(np.atleast_1d(np.asarray(sigma, dtype=float)) ** 2 * np.ones(len(idx)))
    else:
        s = np.asarray(covariance, dtype=float).reshape(len(idx), len(idx))
    c = np.asarray(unc.cov, dtype=float)
    g = np.linalg.solve(c[np.ix_(idx, idx)], c[idx, :]).T  # (p, h); a held row is its unit vector
    cov = c - g @ c[idx, :] + g @ s @ g.T
    std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    scale = np.outer(std, std)  # a value held exactly (sigma 0) is correlated with nothing
    corr = np.divide(cov, scale, out=np.eye(len(std)), where=scale > 0)
    return dataclasses.replace(unc, cov=cov, std=std, corr=corr, dof=unc.dof + len(idx))
