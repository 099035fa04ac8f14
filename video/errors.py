"""Errors of the video stage."""


class VideoError(ValueError):
    """A film that cannot be used as it is (unreadable, no frames, no tape or targets
    found, an impossible frame rate): the message is one line saying what and where."""


class NoTapeError(VideoError):
    """No reference tape in the frame: the scale must come from elsewhere (the hub targets
    and the vehicle's wheelbase, :func:`video.calibrate_scale.scale_from_hubs`)."""
