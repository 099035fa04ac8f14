"""``identify frames VIDEO --out DIR [--every N] [--scaled]``: the film as numbered images.

The paper's first step: split the film into single PNG images (every N-th frame). With
``--scaled`` each image is rectified to the car's metric plane (square pixels of a known
size in metres), with a scale bar and the time since first contact written on it.
"""

from __future__ import annotations

import argparse


def register(subparsers) -> None:
    """Add the ``frames`` parser to ``subparsers`` and set ``func=run``."""
    p = subparsers.add_parser(
        "frames",
        help="split a film into numbered PNG images (optionally scaled, with time)",
        description="Split a film into numbered PNG images, every N-th frame. With --scaled, "
        "images are resampled to the car's plane at a known m/px, with a scale bar and the "
        "time since first contact.",
    )
    p.add_argument("video", help="video file (MP4, AVI, MOV ...) or folder of numbered frames")
    p.add_argument("--out", required=True, help="folder for the images (created)")
    p.add_argument("--every", type=int, default=1, help="keep every N-th frame (default 1)")
    p.add_argument("--fps", type=float, default=None, help="true recording rate if the container's is wrong")
    p.add_argument("--scaled", action="store_true", help="rectify to the car plane, draw a scale bar and the time since contact")
    p.add_argument("--tape-segment", type=float, default=0.1, help="reference-tape segment length, m (default 0.1), for --scaled")
    p.add_argument("--mm-per-px", type=float, default=None, help="output resolution for --scaled, mm per px (default: the film's own)")
    p.add_argument("--contact-frame", type=int, default=None, help="index of the first-contact frame for the times written with --scaled")
    p.add_argument("--vehicle", default=None, help="with --scaled and no --contact-frame: vehicle name or TOML, to measure the contact frame by tracking the film")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Write the images into ``args.out``; return 0.

    Bad input raises VideoError (film) or UserError (options). The images go to a
    temporary folder that is renamed into place at the end, so an interrupted run never
    leaves a half-filled output folder.
    """
    import sys
    from pathlib import Path

    from identify.errors import UserError

    if args.every < 1:
        raise UserError(f"--every must be a positive whole number, got {args.every}")
    from identify.report.results import make_temp_dir, remove_temp

    out = Path(args.out)
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise UserError(f"output folder {out} already exists and is not empty; choose another --out or remove it")
    # the temporary sibling is made before any work: an unwritable place fails now
    tmp = make_temp_dir(out.parent, out.name)
    try:
        written = _write_frames(args, out, tmp)
    except BaseException:
        remove_temp(tmp)
        raise
    if not args.quiet:
        print(f"frames: wrote {written} image(s) to {out}", file=sys.stderr)
    return 0


def _write_frames(args, out, tmp) -> int:
    import sys

    import cv2

    from identify.errors import UserError
    from identify.report.results import _unregister
    from video.io import open_film

    film = open_film(args.video, fps=args.fps)
    source = film.as_color() if film.is_color else film  # images keep the film's colours
    tty = sys.stderr.isatty()
    shown = {"tenth": -1}

    def progress(done: int, total: int) -> None:
        if args.quiet:
            return
        if tty:  # one line redrawn on a terminal; whole lines every 10 % into a file or pipe
            print(f"\rframes: {done}/{total}", file=sys.stderr, end="", flush=True)
        elif int(10 * done / total) > shown["tenth"]:
            shown["tenth"] = int(10 * done / total)
            print(f"frames: {done}/{total}", file=sys.stderr, flush=True)

    draw = None
    if args.scaled:
        draw = _scaled_drawer(film, args)

    digits = max(5, len(str(film.n_frames - 1)))
    written = 0
    for i, frame in enumerate(source):
        if i % args.every:
            continue
        image = draw(i, frame) if draw is not None else frame
        name = tmp / f"frame_{i:0{digits}d}.png"
        if not cv2.imwrite(str(name), image):
            raise UserError(f"cannot write {name}; check that the disk has space and the folder is writable")
        written += 1
        progress(i + 1, film.n_frames)
    if not args.quiet and tty:
        print(file=sys.stderr)
    for note in film.notes:
        print(f"note: {note}", file=sys.stderr)
    from identify.report.results import _LOCK, current_umask

    mask = current_umask()
    tmp.chmod(0o777 & ~mask)
    for f in tmp.iterdir():
        f.chmod(0o666 & ~mask)
    with _LOCK:
        if out.exists():
            out.rmdir()
        tmp.rename(out)
        _unregister(tmp)
    return written


def _scaled_drawer(film, args):
    """Return ``draw(i, frame) -> image`` that rectifies a frame to the car's plane.

    The scale (m/px) and the lens distortion come from the reference tapes of the first
    frame (``video.calibrate.measure_scale``). The camera looks perpendicular to the
    car's side, so rectifying is removing the distortion and resampling to square pixels
    of ``--mm-per-px``. Times are from ``--contact-frame`` or the tracking stage's contact
    detection (``video.track.track_film``, needs ``--vehicle``), else from the film's first
    frame (said on the image).
    """
    import sys

    from identify.errors import UserError
    from video import calibrate

    if args.mm_per_px is not None and not (0.01 <= args.mm_per_px <= 1000.0):
        raise UserError(f"--mm-per-px {args.mm_per_px} makes no sense; give the output pixel size in mm, e.g. 4")
    est = calibrate.measure_scale(film[0], args.tape_segment)
    out_m = est.m_per_px if args.mm_per_px is None else args.mm_per_px / 1000.0
    contact, contact_source = _contact_frame(film, args)
    for note in est.notes:
        if note:
            print(f"note: {note}", file=sys.stderr)
    if contact is None:
        print("note: first contact not known: times written are from the film's first frame; "
              "give --contact-frame, or --vehicle to measure it, to count from contact", file=sys.stderr)
    elif contact_source == "tracked" and not args.quiet:
        print(f"frames: first contact measured at frame {contact}", file=sys.stderr)
    maps = rectify_maps(film.size, est.m_per_px, out_m, est.lens if est.lens.corrected else None)
    scale = Annotation(out_m, film.fps, contact, est.sigma / est.m_per_px)

    def draw(i, frame):
        import cv2

        img = cv2.remap(frame, maps[0], maps[1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        return scale.draw(img, i)

    return draw


def _contact_frame(film, args):
    """(index or None, where it came from)."""
    if args.contact_frame is not None:
        if not 0 <= args.contact_frame < film.n_frames:
            from identify.errors import UserError

            raise UserError(f"--contact-frame {args.contact_frame} is outside the film (0..{film.n_frames - 1})")
        return args.contact_frame, "user"
    if args.vehicle is None:
        return None, "unknown"
    from identify.commands.track import load_car_geometry
    from video.track import track_film

    tracks = track_film(film, load_car_geometry(args.vehicle), tape_segment_m=args.tape_segment)
    return int(tracks.contact_frame), "tracked"


def rectify_maps(size, m_per_px_in, m_per_px_out, lens=None):
    """Sampling maps from an output image in the car plane to the recorded frame.

    Parameters
    ----------
    size : (width, height)
        Recorded frame size, px.
    m_per_px_in : float
        Scale of the undistorted recorded frame in the car plane, m/px.
    m_per_px_out : float
        Pixel size of the output image, m/px.
    lens : video.calibrate.LensDistortion or None
        Radial distortion to remove (None: none).

    Returns
    -------
    (map_u, map_v) : two (H_out, W_out) float32
        For each output pixel, where to sample the recorded frame (``cv2.remap``);
        the output covers the same field of view as the input.
    """
    import numpy as np

    from video import calibrate

    w, h = size
    ratio = m_per_px_out / m_per_px_in  # input px per output px
    wo, ho = max(1, int(round(w / ratio))), max(1, int(round(h / ratio)))
    uo, vo = np.meshgrid(np.arange(wo, dtype=np.float64), np.arange(ho, dtype=np.float64))
    pu = (uo + 0.5) * ratio - 0.5
    pv = (vo + 0.5) * ratio - 0.5
    pts = np.stack([pu.ravel(), pv.ravel()], axis=1)
    if lens is not None:
        pts = calibrate.distort_points(pts, lens)
    return pts[:, 0].reshape(ho, wo).astype(np.float32), pts[:, 1].reshape(ho, wo).astype(np.float32)


class Annotation:
    """Scale bar and time label drawn on rectified frames.

    Parameters
    ----------
    m_per_px : float
        Pixel size of the image drawn on, m/px.
    fps : float
        Frames per second.
    contact : int or None
        First-contact frame (times are since contact), or None (times since the
        first frame).
    rel_sigma : float
        Relative one-sigma uncertainty of the scale, written beside the bar.
    """

    def __init__(self, m_per_px, fps, contact, rel_sigma):
        self.m_per_px = m_per_px
        self.fps = fps
        self.contact = contact
        self.rel_sigma = rel_sigma

    def bar_length_m(self, width_px):
        """A round bar length (m) about a fifth of the image width."""
        target = 0.2 * width_px * self.m_per_px
        for L in (0.01, 0.02, 0.05, 0.1, 0.2, 0.25, 0.5, 1.0, 2.0, 5.0, 10.0):
            if L >= target * 0.7:
                return L
        return 10.0

    def label(self, i):
        """Time text of frame ``i``."""
        if self.contact is None:
            return f"frame {i}  t = {1000.0 * i / self.fps:.1f} ms from first frame"
        return f"frame {i}  t = {1000.0 * (i - self.contact) / self.fps:+.1f} ms since contact"

    def draw(self, img, i):
        """Return a BGR copy of ``img`` with the scale bar and the time of frame ``i``."""
        import cv2

        out = cv2.cvtColor(img, cv2.COLOR_GRAY2BGR) if img.ndim == 2 else img.copy()
        h, w = out.shape[:2]
        L = self.bar_length_m(w)
        n = L / self.m_per_px
        fs = max(0.35, min(1.0, w / 1400.0))
        th = 1 if fs < 0.6 else 2
        x0, y0 = 12, h - 14
        cv2.rectangle(out, (x0 - 6, y0 - 34), (int(x0 + n + 150 * fs), h - 2), (0, 0, 0), -1)
        cv2.rectangle(out, (x0, y0 - 8), (int(round(x0 + n)), y0), (255, 255, 255), -1)
        text = f"{L * 100:g} cm" if L < 1 else f"{L:g} m"
        cv2.putText(out, f"{text}  ({100 * self.rel_sigma:.2f} %)", (x0, y0 - 14), cv2.FONT_HERSHEY_SIMPLEX, fs, (255, 255, 255), th, cv2.LINE_AA)
        (tw, tht), _ = cv2.getTextSize(self.label(i), cv2.FONT_HERSHEY_SIMPLEX, fs, th)
        cv2.rectangle(out, (6, 4), (18 + tw, 16 + tht), (0, 0, 0), -1)
        cv2.putText(out, self.label(i), (12, 10 + tht), cv2.FONT_HERSHEY_SIMPLEX, fs, (0, 255, 255), th, cv2.LINE_AA)
        return out
