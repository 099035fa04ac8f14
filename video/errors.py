"""Errors of the video stage."""


class VideoError(ValueError):
    """A film that cannot be used as it is (unreadable, no frames, no tape or targets
    found, an impossible frame rate): the message is one line saying what and where."""
