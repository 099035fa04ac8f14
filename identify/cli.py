"""The ``identify`` command line.

Each sub-command lives in its own module under ``identify/commands/``; the module has
``register(subparsers)``, which adds its parser and sets ``func`` to a function
``run(args) -> int``. Heavy imports (JAX, OpenCV) happen inside ``run`` so that
``identify --help`` answers at once.

Bad input of any kind ends in one line on stderr and exit code 2, never a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from identify.errors import UserError

COMMANDS = ("fit", "track", "frames", "simulate", "sensitivity", "vehicles", "synth")

EXIT_BAD_INPUT = 2
EXIT_INTERNAL_ERROR = 1  # a bug: still one line, never a traceback (IDENTIFY_DEBUG=1 shows it)


def build_parser() -> argparse.ArgumentParser:
    """Return the argument parser with every sub-command of ``COMMANDS`` registered."""
    parser = argparse.ArgumentParser(
        prog="identify",
        description="Identify collision-model parameters from crash-test recordings.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in COMMANDS:
        importlib.import_module(f"identify.commands.{name}").register(sub)
    return parser


def _bad_input_types() -> tuple[type[BaseException], ...]:
    """Exception types that mean 'bad input' (each package defines its own)."""
    from sim.errors import ConfigError
    from video.errors import VideoError

    return (UserError, ConfigError, VideoError, FileNotFoundError)


def _quiet_native_libraries() -> None:
    """FFmpeg and OpenCV print their own lines on stderr before ours; silence them (set
    before cv2 is imported; a user's own setting wins)."""
    import os

    os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")  # AV_LOG_QUIET
    os.environ.setdefault("OPENCV_LOG_LEVEL", "OFF")
    os.environ.setdefault("OPENCV_VIDEOIO_DEBUG", "0")
    os.environ.setdefault("TF_CPP_MIN_LOG_LEVEL", "3")  # XLA's slow-compile banners


def _describe(err: BaseException) -> tuple[str, bool]:
    """The one line for ``err`` and whether it is bad input (else an internal error)."""
    if isinstance(err, _bad_input_types()):
        return str(err), True
    if isinstance(err, UnicodeDecodeError):
        return f"a file holds bytes that are not text ({err.reason} at byte {err.start})", True
    if isinstance(err, OSError):
        where = f" {err.filename}" if err.filename else ""
        return f"cannot use{where}: {err.strerror or err}", True
    if isinstance(err, MemoryError):
        return "out of memory: the input is too large for this computer", True
    text = str(err).splitlines()[0] if str(err) else ""
    return (f"unexpected {type(err).__name__}{': ' + text if text else ''} (a bug: please report it with the "
            "command; IDENTIFY_DEBUG=1 shows the traceback)"), False


def _run_in_worker(func, args):
    """Run ``func(args)`` in a worker thread while the main thread waits, so that Ctrl-C is
    honoured at once even while JAX compiles in C++ (which holds off Python's handler).
    On Ctrl-C the temporaries of a write in progress are removed (a commit moving files
    into place is let finish) and the process exits 130 without waiting for the worker."""
    import os
    import threading

    box: dict = {}

    def work():
        try:
            box["code"] = func(args)
        except BaseException as err:  # re-raised in the main thread
            box["error"] = err

    worker = threading.Thread(target=work, name=f"identify-{args.command}", daemon=True)
    worker.start()
    try:
        while worker.is_alive():
            worker.join(0.05)
    except KeyboardInterrupt:
        from identify.report.results import discard_temporaries

        discard_temporaries()
        try:
            sys.stdout.flush()
        except Exception:
            pass
        os.write(_STDERR_FD, f"\nidentify {args.command}: interrupted\n".encode())
        os._exit(130)
    if "error" in box:
        raise box["error"]
    return box.get("code")


_STDERR_FD = 2


def main(argv: list[str] | None = None) -> int:
    """Run the command line; return the process exit code."""
    try:
        return _main(argv)
    except KeyboardInterrupt:  # Ctrl-C while starting up, before the work began
        print("identify: interrupted", file=sys.stderr)
        return 130


def _main(argv: list[str] | None) -> int:
    import os
    import threading

    global _STDERR_FD
    _quiet_native_libraries()
    parser = build_parser()
    args = parser.parse_args(argv)
    if getattr(args, "compiles", False):
        from identify.compile_cache import enable

        enable()
    try:  # a copy of stderr that a decoder's silencing of fd 2 cannot take away (Ctrl-C's line)
        _STDERR_FD = os.dup(2)
    except OSError:
        _STDERR_FD = 2
    try:
        if threading.current_thread() is threading.main_thread() and not os.environ.get("IDENTIFY_NO_THREAD"):
            return int(_run_in_worker(args.func, args) or 0)
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        from identify.report.results import discard_temporaries

        discard_temporaries()
        print(f"identify {args.command}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # `identify vehicles | head -3`: the reader has gone; quietly, as `cat` does
        try:
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, sys.stdout.fileno())
        except (OSError, ValueError, AttributeError):
            pass
        return 141
    except Exception as err:
        if os.environ.get("IDENTIFY_DEBUG"):
            raise
        message, bad_input = _describe(err)
        message = " ".join(message.split())  # one line, whatever the message holds
        print(f"identify {args.command}: error: {message}", file=sys.stderr)
        return EXIT_BAD_INPUT if bad_input else EXIT_INTERNAL_ERROR
    finally:
        if _STDERR_FD != 2:
            os.close(_STDERR_FD)
            _STDERR_FD = 2


if __name__ == "__main__":
    sys.exit(main())
