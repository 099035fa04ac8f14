"""Errors of the collision model."""


class ConfigError(ValueError):
    """A vehicle or parameter configuration that cannot be simulated: the message names
    the field, its value and what would be valid. Nothing is clamped silently."""
