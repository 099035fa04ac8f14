"""The fit's weighted least-squares pieces that do not depend on the crash model: a
channel's residual rows, the residuals' correlation time, and the parameters' covariance.

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


def integrated_autocorrelation_time(residual: np.ndarray, max_lag: int = 50) -> float:
    """tau = 1 + 2 * sum of the residual's autocorrelations, summed over lags while the
    sums of neighbouring pairs stay positive (Geyer's initial positive sequence); 1 for
    white noise, larger when neighbouring samples' errors are alike (an AR(1) process of
    coefficient phi has tau = (1 + phi) / (1 - phi)). Never below 1."""
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


@dataclasses.dataclass
class Uncertainty:
    """Covariance of fitted parameters (physical units) and what it was made from.

    cov, std, corr : covariance (unit_i unit_j), standard deviations, correlations.
    chi2 : sum of squared residual rows; dof : residual count - fitted parameters.
    scale : max(1, chi2/dof), the factor the covariance was widened by for a misfit larger
        than the stated noise. tau : channel -> residual correlation time (samples).
    """

    cov: np.ndarray
    std: np.ndarray
    corr: np.ndarray
    chi2: float
    dof: int
    scale: float
    tau: dict


def parameter_covariance(r, jac_u, dvalue_du, typical, channel_rows: dict, n_res: int) -> Uncertainty:
    """Covariance of the fitted parameters at a least-squares optimum.

    r : (m,) weighted residual rows at the optimum; jac_u : (m, p) their Jacobian with
    respect to the unconstrained parameters u; dvalue_du : (p,) derivative of each physical
    value with respect to its u (positive: the transforms are increasing); typical : (p,)
    each parameter's typical magnitude (physical units); channel_rows : channel -> indices
    of its valid rows in r (rows of no channel, the priors, are taken as independent);
    n_res : number of residuals that carry information (valid samples and priors).

    Gauss-Newton: cov = scale * (J^T J)^-1 with J the Jacobian in physical units (J_u divided
    by dvalue/du, the chain rule). Each channel's rows are divided by sqrt(tau), its
    residuals' correlation time: n correlated samples weigh as n / tau independent ones. The
    inversion runs on columns scaled to ``typical`` (well conditioned), and an eigenvalue
    near 0 (a direction the data do not constrain) is floored, giving that direction a huge
    variance, not the zero a pseudo-inverse would give it.
    """
    r, jac_u, dvalue_du, typical = (np.asarray(a, dtype=float) for a in (r, jac_u, dvalue_du, typical))
    chi2 = float(r @ r)
    dof = max(int(n_res) - len(typical), 1)
    scale = max(1.0, chi2 / dof)
    tau = {name: integrated_autocorrelation_time(r[rows]) for name, rows in channel_rows.items()}
    row_weight = np.ones(len(r))
    for name, rows in channel_rows.items():
        row_weight[rows] = 1.0 / math.sqrt(tau[name])
    jac_s = row_weight[:, None] * jac_u / np.maximum(dvalue_du, 1e-300)[None, :] * typical[None, :]
    eigval, eigvec = np.linalg.eigh(jac_s.T @ jac_s)
    eigval = np.maximum(eigval, 1e-14 * max(float(eigval.max()), 1e-300))
    cov = (eigvec / eigval) @ eigvec.T * scale * np.outer(typical, typical)
    std = np.sqrt(np.diag(cov))  # > 0: every eigenvalue was floored above 0
    corr = cov / np.outer(std, std)
    return Uncertainty(cov=cov, std=std, corr=corr, chi2=chi2, dof=dof, scale=scale, tau=tau)
