"""Helpers for the tests: a central finite-difference Jacobian to check autodiff against."""

import numpy as np


def central_difference_jacobian(f, x0, rel_step=1e-6):
    """Jacobian of ``f: (p,) -> (n,)`` at ``x0`` by central differences, steps
    ``rel_step * max(|x0_i|, 1)``; returns (n, p)."""
    x0 = np.asarray(x0, dtype=float)
    cols = []
    for i in range(len(x0)):
        h = rel_step * max(abs(x0[i]), 1.0)
        up, down = x0.copy(), x0.copy()
        up[i] += h
        down[i] -= h
        cols.append((np.asarray(f(up)) - np.asarray(f(down))) / (2 * h))
    return np.stack(cols, axis=1)
