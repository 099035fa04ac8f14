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

COMMANDS = ("fit", "track", "frames", "simulate", "sensitivity", "vehicles")

EXIT_BAD_INPUT = 2


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


def main(argv: list[str] | None = None) -> int:
    """Run the command line; return the process exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except _bad_input_types() as err:
        print(f"identify {args.command}: error: {err}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print(f"identify {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
