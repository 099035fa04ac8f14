"""Writers of rendered frames: MP4 (H.264 at a chosen bitrate), AVI (MJPEG), a folder of
PNG frames or a folder of 16-bit TIFF frames.

MP4 goes through PyAV (``av``, FFmpeg's libraries with libx264) because OpenCV's
``VideoWriter`` cannot set a bitrate: crash films handed to the tool are often
re-encoded at a low bitrate, and their block artefacts are part of what the tracker
must cope with. Without PyAV an MP4 is written by OpenCV (codec mp4v, its own bitrate)
and the truth says so.

Example
-------
>>> with FilmWriter("crash.mp4", "mp4", 1024, 818, fps=25.0, bitrate=2e6) as w:   # doctest: +SKIP
...     w.write(frame_float)                                                     # doctest: +SKIP
"""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path

import cv2
import numpy as np

from synth.vehicle import SynthError

FORMATS = ("mp4", "avi", "png", "tiff16")


class FilmWriter:
    """Write frames (float grey levels 0-255, or uint8) one at a time.

    Parameters
    ----------
    path : str or Path
        ``*.mp4`` / ``*.avi`` file, or a folder (created; must not hold frames) for
        ``png`` / ``tiff16`` (``frame_00000.png`` / ``frame_00000.tif`` ...).
    fmt : str
        One of :data:`FORMATS`.
    width, height : int
        Frame size, px (even for MP4).
    fps : float
        Rate written into the container (MP4/AVI).
    bitrate : float
        MP4 bitrate, bit/s of container time.
    quality : int
        AVI (MJPEG) quality 1-100.

    Attributes
    ----------
    encoder : str
        What wrote the film (e.g. ``"libx264 (PyAV 14.0.1)"``), for the truth.
    """

    def __init__(self, path, fmt: str, width: int, height: int, fps: float, bitrate: float = 4e6,
                 quality: int = 80):
        if fmt not in FORMATS:
            raise SynthError(f"unknown film format {fmt!r}: use one of {', '.join(FORMATS)}")
        self.path = Path(path)
        self.fmt = fmt
        self.width, self.height = int(width), int(height)
        self.k = 0
        self._container = self._stream = self._cv = None
        if fmt in ("png", "tiff16"):
            self.path.mkdir(parents=True, exist_ok=True)
            if any(self.path.glob("frame_*")):
                raise SynthError(f"folder {self.path} already holds frames; write the film to a new folder")
            self.encoder = "opencv imwrite " + ("PNG 8-bit" if fmt == "png" else "TIFF 16-bit")
            return
        self.path.parent.mkdir(parents=True, exist_ok=True)
        if fmt == "avi":
            self._cv = cv2.VideoWriter(str(self.path), cv2.CAP_OPENCV_MJPEG, cv2.VideoWriter_fourcc(*"MJPG"),
                                       float(fps), (self.width, self.height), True)
            if not self._cv.isOpened():
                raise SynthError(f"cannot write {self.path} (no MJPEG writer)")
            self._cv.set(cv2.VIDEOWRITER_PROP_QUALITY, float(quality))
            self.encoder = f"opencv MJPEG quality {int(quality)}"
            return
        try:
            import av
        except ImportError:
            av = None
        if av is not None and "libx264" in av.codecs_available:
            if self.width % 2 or self.height % 2:
                raise SynthError(f"MP4 (yuv420p) needs an even frame size, got {self.width}x{self.height}")
            self._container = av.open(str(self.path), "w")
            rate = Fraction(float(fps)).limit_denominator(1001)
            self._stream = self._container.add_stream("libx264", rate=rate)
            self._stream.width, self._stream.height = self.width, self.height
            self._stream.pix_fmt = "yuv420p"
            self._stream.bit_rate = int(bitrate)
            self._stream.options = {"preset": "ultrafast"}
            self.encoder = f"libx264 {int(bitrate)} bit/s (PyAV {av.__version__})"
        else:
            self._cv = cv2.VideoWriter(str(self.path), cv2.VideoWriter_fourcc(*"mp4v"), float(fps),
                                       (self.width, self.height), True)
            if not self._cv.isOpened():
                raise SynthError(f"cannot write {self.path} (no MP4 encoder); write a folder of PNG frames instead")
            self.encoder = "opencv mp4v (PyAV not installed: bitrate not set)"

    def write(self, frame: np.ndarray) -> None:
        """Append one (height, width) frame: float grey levels 0-255 or uint8."""
        f = np.asarray(frame)
        if self.fmt == "tiff16":
            out = np.clip(f.astype(np.float32) * 257.0 + 0.5, 0, 65535).astype(np.uint16)
            # uncompressed: 16-bit frames with sensor noise hardly compress, and LZW is slow
            cv2.imwrite(str(self.path / f"frame_{self.k:05d}.tif"), out,
                        [cv2.IMWRITE_TIFF_COMPRESSION, cv2.IMWRITE_TIFF_COMPRESSION_NONE])
        else:
            out = f if f.dtype == np.uint8 else np.clip(f + 0.5, 0, 255).astype(np.uint8)
            if self.fmt == "png":
                cv2.imwrite(str(self.path / f"frame_{self.k:05d}.png"), out,
                            [cv2.IMWRITE_PNG_COMPRESSION, 1, cv2.IMWRITE_PNG_STRATEGY, cv2.IMWRITE_PNG_STRATEGY_HUFFMAN_ONLY])
            elif self._stream is not None:
                import av

                vf = av.VideoFrame.from_ndarray(np.ascontiguousarray(out), format="gray")
                for packet in self._stream.encode(vf):
                    self._container.mux(packet)
            else:  # OpenCV's own MJPEG encoder fails on some grayscale frames: write BGR
                self._cv.write(cv2.cvtColor(out, cv2.COLOR_GRAY2BGR))
        self.k += 1

    def close(self) -> None:
        """Flush and close the film."""
        if self._stream is not None:
            for packet in self._stream.encode():
                self._container.mux(packet)
            self._container.close()
            self._stream = None
        if self._cv is not None:
            self._cv.release()
            self._cv = None

    def __enter__(self) -> "FilmWriter":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
