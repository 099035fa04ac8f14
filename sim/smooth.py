"""Smooth stand-ins for the kinks of contact and friction laws.

Each takes a width in the physical unit of its argument, so that a smoothing width is a
named, physically meaningful number (a force in N, a speed in m/s, a length in m), and
the model stays differentiable everywhere.
"""

import jax
import jax.numpy as jnp


def smooth_relu(x, width):
    """``max(0, x)`` smoothed over ``width`` (same unit as x): ``width * log(1 + exp(x/width))``.

    Within a few widths of zero it departs from max(0, x) by at most ``width * log 2``.
    """
    return width * jnp.logaddexp(0.0, x / width)


def smooth_step(x, width):
    """Heaviside step of ``x`` smoothed over ``width``: a logistic, 0.5 at x = 0."""
    return jax.nn.sigmoid(x / width)


def smooth_sign(x, width):
    """``sign(x)`` smoothed over ``width``: ``tanh(x / width)``."""
    return jnp.tanh(x / width)
