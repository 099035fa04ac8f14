"""Reading films: video files (MP4/AVI/MOV, anything FFmpeg reads) and folders of numbered
frames (PNG/TIFF/JPEG/BMP), streamed frame by frame.

Frames are returned as uint8 arrays: grayscale ``(H, W)`` by default, BGR ``(H, W, 3)``
with ``color=True``. Opening a film makes one pass that checks every frame decodes,
counts them, checks their sizes and looks for duplicated frames (keeping two numbers per
frame); it keeps the frames it decoded while they take at most :data:`KEEP_DECODED_BYTES`
(read-only: every reader shares them), and the film is read from them until it is closed.
A longer or larger film is never held in memory: its frames are decoded again on demand.

Example
-------
>>> film = open_film("crash.mp4", fps=1000.0)       # doctest: +SKIP
>>> for i, frame in enumerate(film):                 # doctest: +SKIP
...     print(i / film.fps, frame.shape)
"""

from __future__ import annotations

import contextlib
import copy
import math
import os
import re
import struct
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

import cv2
import numpy as np

from video.errors import VideoError

VIDEO_SUFFIXES = (".mp4", ".avi", ".mov", ".mkv", ".m4v", ".wmv", ".mpg", ".mpeg", ".webm")
IMAGE_SUFFIXES = (".png", ".tif", ".tiff", ".jpg", ".jpeg", ".bmp")

#: Container rates at or below this are publication rates, not a high-speed camera's.
LOW_CONTAINER_FPS = 200.0
#: Largest frame rate accepted, frames per second.
MAX_FPS = 1.0e6
#: Frame rate assumed for a folder of frames when none is given, frames per second.
DEFAULT_FOLDER_FPS = 1000.0
#: Largest frame accepted, px a side and px in all: a high-speed camera's frames are a few
#: megapixels; a header claiming more is damaged (and decoding it would exhaust memory).
MAX_FRAME_SIDE = 16384
MAX_FRAME_PIXELS = 40_000_000
#: The opening scan keeps the frames it decodes while they take no more than this, bytes
#: (a 1280x1024 grey film of 800 frames): the stage then reads them from memory instead of
#: decoding the film again, which cost as much as the scan itself (``benchmarks/bench_video.py``).
#: A longer or larger film is decoded again as it is read.
KEEP_DECODED_BYTES = 1 << 30


def check_frame_size(width: int, height: int, where: str) -> None:
    """Raise VideoError unless a ``width`` x ``height`` frame is within the decoding limits."""
    if width <= 0 or height <= 0:
        raise VideoError(f"{where} declares a frame of {width}x{height} px; the file is damaged")
    if width > MAX_FRAME_SIDE or height > MAX_FRAME_SIDE or width * height > MAX_FRAME_PIXELS:
        raise VideoError(
            f"{where} declares frames of {width}x{height} px ({width * height / 1e6:.0f} MP); the limit is "
            f"{MAX_FRAME_SIDE} px a side and {MAX_FRAME_PIXELS / 1e6:.0f} MP (high-speed cameras record a few MP): "
            "the file is damaged, or scale the frames down")


def image_header_size(path: Path) -> tuple[int, int] | None:
    """``(width, height)`` a PNG, JPEG, BMP or TIFF file declares in its header, read
    without decoding the image; None when the header is not one of these or is unreadable."""
    try:
        with open(path, "rb") as f:
            head = f.read(65536)
    except OSError:
        return None
    try:
        if head[:8] == b"\x89PNG\r\n\x1a\n" and head[12:16] == b"IHDR":
            return struct.unpack(">II", head[16:24])
        if head[:2] == b"BM" and len(head) >= 26:
            w, h = struct.unpack("<ii", head[18:26])
            return w, abs(h)
        if head[:2] == b"\xff\xd8":
            i = 2
            while i + 9 < len(head):
                if head[i] != 0xFF:
                    return None
                marker = head[i + 1]
                if marker in (0xD8, 0x01) or 0xD0 <= marker <= 0xD7:
                    i += 2
                    continue
                length = struct.unpack(">H", head[i + 2:i + 4])[0]
                if 0xC0 <= marker <= 0xCF and marker not in (0xC4, 0xC8, 0xCC):
                    h, w = struct.unpack(">HH", head[i + 5:i + 9])
                    return w, h
                i += 2 + length
            return None
        if head[:4] in (b"II*\x00", b"MM\x00*"):
            e = "<" if head[:2] == b"II" else ">"
            off = struct.unpack(e + "I", head[4:8])[0]
            n = struct.unpack(e + "H", head[off:off + 2])[0]
            size = {}
            for k in range(n):
                tag, typ, _count = struct.unpack(e + "HHI", head[off + 2 + 12 * k:off + 10 + 12 * k])
                raw = head[off + 10 + 12 * k:off + 14 + 12 * k]
                if tag in (256, 257):
                    size[tag] = struct.unpack(e + "H", raw[:2])[0] if typ == 3 else struct.unpack(e + "I", raw)[0]
            if 256 in size and 257 in size:
                return size[256], size[257]
    except (struct.error, IndexError):
        return None
    return None


@contextlib.contextmanager
def native_stderr_silenced():
    """Send what native libraries (libpng, FFmpeg) print on file descriptor 2 to nowhere
    for the duration: a damaged file is reported by our one line, not by theirs before it.
    Python's own ``sys.stderr`` writes made meanwhile are lost too, so keep it short."""
    try:
        sys.stderr.flush()
    except (AttributeError, ValueError, OSError):
        pass
    try:
        saved = os.dup(2)
        devnull = os.open(os.devnull, os.O_WRONLY)
    except OSError:
        yield
        return
    try:
        os.dup2(devnull, 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        os.close(devnull)


@dataclass(frozen=True)
class DuplicateCheck:
    """Settings of the duplicated-frame test.

    Two consecutive frames are duplicates when their mean absolute difference is below
    ``noise_fraction`` times what two independent exposures of a still scene would give
    (``2 sigma / sqrt(pi)``, sigma the frame's estimated sensor noise, grey levels), or
    below ``floor`` grey levels: the noise of a duplicated frame is not independent.
    """

    noise_fraction: float = 0.3
    floor: float = 0.05
    step: int = 2  # compare every ``step``-th pixel in each direction (speed)


def natural_key(name: str) -> list:
    """Sort key that orders ``frame2`` before ``frame10``."""
    return [int(part) if part.isdigit() else part.lower() for part in re.split(r"(\d+)", name)]


def check_fps(fps: float, where: str) -> float:
    """Return ``fps`` as a float, or raise VideoError if it is not a usable frame rate.

    Parameters
    ----------
    fps : float
        Frames per second.
    where : str
        Where the rate came from, for the message (``"--fps"``, a file name).
    """
    try:
        value = float(fps)
    except (TypeError, ValueError):
        raise VideoError(f"frame rate {fps!r} from {where} is not a number; give --fps, e.g. --fps 1000") from None
    if not math.isfinite(value) or value <= 0.0 or value > MAX_FPS:
        raise VideoError(
            f"frame rate {value!r} from {where} makes no sense (must be > 0 and <= {MAX_FPS:g}); "
            "give the true recording rate with --fps, e.g. --fps 1000"
        )
    return value


def frame_noise_sigma(gray: np.ndarray, row_step: int = 8) -> float:
    """Estimate the sensor noise of a frame, grey levels (robust, edges mostly ignored).

    Parameters
    ----------
    gray : (H, W) uint8 or float
    row_step : int
        Use every ``row_step``-th row (speed).

    Returns
    -------
    float
        One-sigma noise from the median absolute horizontal second difference
        (``sqrt(6) sigma`` for white noise).
    """
    rows = np.asarray(gray[::row_step])
    if rows.shape[1] < 3 or rows.size == 0:
        return 0.0
    if rows.dtype.kind in "ui":
        # bytes: second differences within +-510, exact in int16 (half the memory traffic)
        r = rows.astype(np.int16 if rows.dtype.itemsize == 1 else np.int32)
        a = np.abs(r[:, :-2] + r[:, 2:] - 2 * r[:, 1:-1]).ravel()
        med = _grouped_median(a)
    else:
        r = rows.astype(np.float64)
        med = float(np.median(np.abs(r[:, :-2] + r[:, 2:] - 2.0 * r[:, 1:-1])))
    return med / 0.6745 / math.sqrt(6.0)


def _grouped_median(a: np.ndarray) -> float:
    """Median of non-negative integers read as values spread over their unit bins
    (bin 0 covers [0, 0.5]): not stuck on whole numbers when the noise is small."""
    counts = np.bincount(a)
    half = 0.5 * a.size
    cdf = np.cumsum(counts)
    L = int(np.searchsorted(cdf, half))
    below = float(cdf[L - 1]) if L > 0 else 0.0
    lo, width = (0.0, 0.5) if L == 0 else (L - 0.5, 1.0)
    return lo + width * (half - below) / max(float(counts[L]), 1.0)


def _to_gray(frame: np.ndarray) -> np.ndarray:
    if frame.ndim == 2:
        return frame
    if frame.shape[2] == 4:
        return cv2.cvtColor(frame, cv2.COLOR_BGRA2GRAY)
    return cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)


def _to_bgr(frame: np.ndarray) -> np.ndarray:
    if frame.ndim == 2:
        return cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR)
    if frame.shape[2] == 4:
        return cv2.cvtColor(frame, cv2.COLOR_BGRA2BGR)
    return frame


def _to_uint8(frame: np.ndarray) -> np.ndarray:
    if frame.dtype == np.uint8:
        return frame
    if frame.dtype == np.uint16:
        return (frame >> 8).astype(np.uint8)
    if np.issubdtype(frame.dtype, np.floating):
        return np.clip(frame * 255.0 if frame.max() <= 1.0 else frame, 0, 255).astype(np.uint8)
    raise VideoError(f"frames of type {frame.dtype} are not supported; convert them to 8- or 16-bit images")


class Film:
    """A film opened for streaming; build it with :func:`open_film`.

    Attributes
    ----------
    path : Path
        The video file or the folder of frames.
    fps : float
        Frames per second used for times.
    fps_source : str
        ``"container"`` (the file's rate), ``"user"`` (given as ``fps``) or ``"assumed"``
        (a folder of frames without a given rate: :data:`DEFAULT_FOLDER_FPS`).
    container_fps : float or None
        The rate the container declares (None for a folder).
    n_frames : int
        Number of frames that decode.
    size : tuple[int, int]
        ``(width, height)`` in px.
    duplicates : (k,) int
        Indices ``i`` of frames that repeat frame ``i - 1`` (re-encoding artefacts).
    is_color : bool
        True if the film's frames have colour (differing BGR channels).
    notes : list[str]
        Things a person should read (wrong container rate, duplicated frames ...).
    """

    def __init__(self, path: Path, files: list[Path] | None, color: bool):
        self.path = path
        self._files = files
        self.color = color
        self.is_color = False  # set by the opening scan: the first frame has colour
        self._color_checked = False
        self._cap: cv2.VideoCapture | None = None
        self._next = 0  # index of the frame the open capture returns next
        self.fps = float("nan")
        self.fps_source = ""
        self.container_fps: float | None = None
        self.n_frames = 0
        self.size = (0, 0)
        self.duplicates = np.zeros(0, dtype=int)
        self.diffs = np.zeros(0)
        self.noise = np.zeros(0)
        self.notes: list[str] = []
        self._kept: list[np.ndarray] | None = None  # the frames as decoded (read-only), or None

    # --- decoding -------------------------------------------------------------------
    @property
    def is_folder(self) -> bool:
        """True for a folder of numbered frames."""
        return self._files is not None

    @property
    def in_memory(self) -> bool:
        """True while the opening scan's frames are kept (reading one costs no decoding)."""
        return self._kept is not None

    @property
    def files(self) -> list[Path]:
        """The frame files of a folder, in natural order (empty for a video file)."""
        return list(self._files or [])

    def as_color(self, color: bool = True) -> "Film":
        """The same film returning BGR ``(H, W, 3)`` frames (or grey with
        ``color=False``), without scanning it again."""
        other = copy.copy(self)
        other.color = color
        other._kept = self._kept if color == self.color else None
        other._cap = None
        other._next = 0
        other.notes = list(self.notes)
        return other

    def _convert(self, raw: np.ndarray) -> np.ndarray:
        raw = _to_uint8(raw)
        if not self._color_checked:
            # first frame decoded (the opening scan): does the film have colour?
            self._color_checked = True
            if raw.ndim == 3 and raw.shape[2] >= 3:
                # chroma of a grey film through a video codec is a few levels of noise
                ycc = cv2.cvtColor(np.ascontiguousarray(raw[::2, ::2, :3]), cv2.COLOR_BGR2YCrCb).astype(np.float32)
                chroma = np.abs(ycc[..., 1:] - 128.0)
                self.is_color = bool(np.percentile(chroma, 99) > 6.0)
        return _to_bgr(raw) if self.color else _to_gray(raw)

    def _read_file(self, i: int) -> np.ndarray:
        path = self._files[i]
        size = image_header_size(path)
        if size is not None:
            check_frame_size(size[0], size[1], f"frame file {path}")
        try:
            raw = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
        except cv2.error:
            raw = None
        if raw is None:
            raise VideoError(f"frame file {path} cannot be read (damaged or not an image); replace or remove it")
        return self._convert(raw)

    def _open_capture(self) -> cv2.VideoCapture:
        try:
            cap = cv2.VideoCapture(str(self.path))
            opened = cap.isOpened()
        except cv2.error:
            opened = False
        if not opened:
            raise VideoError(f"cannot open video {self.path} (damaged, truncated or an unknown format); re-export it as MP4 or a folder of PNG frames")
        check_frame_size(int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)), int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT)),
                         f"video {self.path}")
        return cap

    def _read_video(self, i: int) -> np.ndarray:
        if self._cap is None or i < self._next:
            if self._cap is not None:
                self._cap.release()
            self._cap = self._open_capture()
            self._next = 0
        while self._next < i:
            if not self._cap.grab():
                raise VideoError(f"video {self.path} ends at frame {self._next} while seeking frame {i}; the file is truncated")
            self._next += 1
        ok, raw = self._cap.read()
        if not ok or raw is None:
            raise VideoError(f"frame {i} of video {self.path} cannot be decoded; the file is truncated or damaged")
        self._next += 1
        return self._convert(raw)

    def frame(self, i: int) -> np.ndarray:
        """Return frame ``i`` (0-based; negative counts from the end).

        Returns
        -------
        (H, W) uint8 grayscale, or (H, W, 3) uint8 BGR if the film was opened with
        ``color=True``; read-only while the film keeps its frames (copy it to change it).
        """
        n = self.n_frames
        if i < 0:
            i += n
        if not 0 <= i < n:
            raise VideoError(f"frame {i} does not exist in {self.path} (it has {n} frames, 0..{n - 1})")
        if self._kept is not None:
            return self._kept[i]
        return self._read_file(i) if self.is_folder else self._read_video(i)

    __getitem__ = frame

    def __len__(self) -> int:
        return self.n_frames

    def __iter__(self) -> Iterator[np.ndarray]:
        """Stream the frames in order (one frame in memory at a time, unless the opening
        scan kept them all: :data:`KEEP_DECODED_BYTES`)."""
        if self._kept is not None:
            yield from self._kept
            return
        if self.is_folder:
            for i in range(self.n_frames):
                yield self._read_file(i)
            return
        cap = self._open_capture()
        try:
            for i in range(self.n_frames):
                ok, raw = cap.read()
                if not ok or raw is None:
                    raise VideoError(f"frame {i} of video {self.path} cannot be decoded; the file is truncated or damaged")
                yield self._convert(raw)
        finally:
            cap.release()

    def times(self) -> np.ndarray:
        """Time of each frame since the first, s, shape (n_frames,)."""
        return np.arange(self.n_frames) / self.fps

    def close(self) -> None:
        """Release the decoder kept for random access and the frames kept from the opening
        scan; the film can still be read (decoded again)."""
        self._kept = None
        if self._cap is not None:
            self._cap.release()
            self._cap = None
            self._next = 0

    def __enter__(self) -> "Film":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __repr__(self) -> str:
        w, h = self.size
        return f"Film({str(self.path)!r}, {self.n_frames} frames, {w}x{h} px, {self.fps:g} fps [{self.fps_source}])"


def _list_frames(folder: Path) -> list[Path]:
    files = [p for p in folder.iterdir() if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES]
    if not files:
        raise VideoError(f"folder {folder} holds no frames (PNG, TIFF, JPEG or BMP files); point to the folder of numbered frames or to a video file")
    suffixes = {p.suffix.lower().replace("jpeg", "jpg").replace("tiff", "tif") for p in files}
    if len(suffixes) > 1:
        raise VideoError(f"folder {folder} mixes frame formats ({', '.join(sorted(suffixes))}); keep one format of numbered frames in it")
    if not any(re.search(r"\d", p.stem) for p in files):
        raise VideoError(f"frames in {folder} are not numbered (e.g. frame_0001.png); number them in time order")
    return sorted(files, key=lambda p: natural_key(p.name))


def _scan(film: Film, check: DuplicateCheck) -> None:
    """Decode every frame once: count, check sizes, measure consecutive differences; keep
    the frames while they fit in :data:`KEEP_DECODED_BYTES` (read-only: every reader shares them)."""
    s = check.step
    kept: list[np.ndarray] | None = []
    diffs: list[float] = []
    noise: list[float] = []
    prev: np.ndarray | None = None
    size: tuple[int, int] | None = None
    count = 0
    if film.is_folder:
        source = (film._read_file(i) for i in range(len(film._files)))
        names = [p.name for p in film._files]
    else:
        source = _scan_video(film)
        names = None
    for i, frame in enumerate(source):
        h, w = frame.shape[:2]
        if size is None:
            size = (w, h)
        elif (w, h) != size:
            where = f"frame file {names[i]}" if names else f"frame {i}"
            raise VideoError(
                f"{where} in {film.path} is {w}x{h} px but the first frame is {size[0]}x{size[1]} px; all frames must have one size"
            )
        full = _to_gray(frame) if film.color else frame
        small = np.ascontiguousarray(full[::s, ::s])
        noise.append(frame_noise_sigma(full))
        diffs.append(float("nan") if prev is None else float(cv2.mean(cv2.absdiff(small, prev))[0]))
        prev = small
        count += 1
        if kept is not None:
            if (len(kept) + 1) * frame.nbytes > KEEP_DECODED_BYTES:  # the frames all have one size
                kept = None
            else:
                frame.flags.writeable = False
                kept.append(frame)
    if count == 0:
        raise VideoError(f"{film.path} has no frames that decode; check the file (re-export it) or the folder")
    film.n_frames = count
    film._kept = kept
    film.size = size
    film.diffs = np.asarray(diffs)
    film.noise = np.asarray(noise)
    expected = 2.0 * film.noise / math.sqrt(math.pi)
    threshold = np.maximum(check.noise_fraction * expected, check.floor)
    dup = np.flatnonzero(film.diffs[1:] < threshold[1:]) + 1
    film.duplicates = dup.astype(int)


def _scan_video(film: Film) -> Iterator[np.ndarray]:
    cap = film._open_capture()
    try:
        declared = cap.get(cv2.CAP_PROP_FRAME_COUNT)
        film.container_fps = cap.get(cv2.CAP_PROP_FPS)
        count = 0
        while True:
            ok, raw = cap.read()
            if not ok or raw is None:
                break
            count += 1
            yield film._convert(raw)
    finally:
        cap.release()
    if declared and declared > 0 and count < 0.98 * declared - 1:
        raise VideoError(
            f"video {film.path} declares {int(declared)} frames but only {count} decode; the file is truncated or damaged, re-export it"
        )
    if declared and declared > 0 and int(round(declared)) != count:
        film.notes.append(f"the container declares {int(round(declared))} frames, {count} decode; using {count}")


def _describe_runs(indices: np.ndarray, limit: int = 12) -> str:
    if indices.size == 0:
        return ""
    runs = []
    start = prev = int(indices[0])
    for i in indices[1:]:
        i = int(i)
        if i == prev + 1:
            prev = i
            continue
        runs.append((start, prev))
        start = prev = i
    runs.append((start, prev))
    text = ", ".join(f"{a}" if a == b else f"{a}-{b}" for a, b in runs[:limit])
    return text + (f" and {len(runs) - limit} more runs" if len(runs) > limit else "")


def open_film(
    path: str | Path,
    fps: float | None = None,
    color: bool = False,
    duplicate_check: DuplicateCheck = DuplicateCheck(),
) -> Film:
    """Open a video file or a folder of numbered frames for streaming.

    Parameters
    ----------
    path : str or Path
        MP4/AVI/MOV (anything FFmpeg reads) or a folder of numbered PNG/TIFF/JPEG/BMP
        frames (sorted naturally: ``f2`` before ``f10``).
    fps : float, optional
        The true recording rate, frames per second; overrides the container's rate
        (which is often a publication rate like 30).
    color : bool
        Return BGR ``(H, W, 3)`` frames instead of grayscale ``(H, W)``.
    duplicate_check : DuplicateCheck
        Settings of the duplicated-frame test.

    Returns
    -------
    Film
        With ``fps``, ``fps_source``, ``n_frames``, ``size`` (w, h px), ``duplicates``,
        ``notes``; iterate it to stream frames, ``film[i]`` for frame ``i``.

    Raises
    ------
    VideoError
        Missing or unreadable file, no frames, frames of different sizes, a truncated
        video, an impossible frame rate.
    """
    path = Path(path)
    if fps is not None:
        fps = check_fps(fps, "--fps")
    if not path.exists():
        raise VideoError(f"film {path} does not exist; give the path of a video file or of a folder of numbered frames")
    if path.is_dir():
        film = Film(path, _list_frames(path), color)
    elif path.suffix.lower() in IMAGE_SUFFIXES:
        raise VideoError(f"{path} is a single image, not a film; give the folder that holds the numbered frames, or a video file")
    else:
        if path.stat().st_size == 0:
            raise VideoError(f"video {path} is empty (0 bytes); copy the film again")
        film = Film(path, None, color)
    with native_stderr_silenced():  # the scan decodes every frame: a damaged one is our one line
        _scan(film, duplicate_check)

    if fps is not None:
        film.fps, film.fps_source = fps, "user"
        if film.container_fps and abs(film.container_fps - fps) > 1e-6 * fps:
            film.notes.append(f"container says {film.container_fps:g} fps; using {fps:g} fps as given")
    elif film.is_folder:
        film.fps, film.fps_source = DEFAULT_FOLDER_FPS, "assumed"
        film.notes.append(
            f"a folder of frames carries no frame rate: assumed {DEFAULT_FOLDER_FPS:g} fps; give --fps if the camera ran at another rate"
        )
    else:
        film.fps, film.fps_source = check_fps(film.container_fps, f"the container of {path.name}"), "container"
        if film.fps <= LOW_CONTAINER_FPS:
            film.notes.append(
                f"the container says {film.fps:g} fps, a publication rate rather than a high-speed camera's; "
                "if the film was shot at e.g. 1000 fps, give --fps 1000"
            )
    if film.duplicates.size:
        film.notes.append(
            f"{film.duplicates.size} frame(s) hardly differ from the one before (a repeat from "
            f"re-encoding, or a still or small moving subject under strong compression): "
            f"{_describe_runs(film.duplicates)}"
        )
    return film
