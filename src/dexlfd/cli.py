"""The ``dexlfd`` command: one subcommand per pipeline stage, plus ``demo``.

Examples
--------
    dexlfd demo -o out/
    dexlfd learn demos/*.npz -o model.npz --plot figures/

Each subcommand lives in ``dexlfd/_commands/<name>.py`` with ``add_parser`` and
``run``; this module only sets up logging, dispatches and maps errors to exit
codes (0 ok, 1 a :class:`~dexlfd.errors.DexlfdError`, 2 usage, 130 interrupted).
"""

from __future__ import annotations

import argparse
import importlib
import logging
import sys
from collections.abc import Sequence

from dexlfd import __version__
from dexlfd.errors import DexlfdError

__all__ = ["main"]

logger = logging.getLogger("dexlfd")

# subcommand name -> module in dexlfd._commands (imported lazily: heavy deps stay unloaded)
COMMANDS: dict[str, str] = {
    "demo": "demo",
    "learn": "learn",
    "synth": "synth",
    "export": "export",
    "plan": "plan",
    "simulate": "simulate",
    "experiment": "experiment",
    "record": "record",
    "teleop": "teleop",
    "calibrate": "calibrate",
}


def _build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="dexlfd",
        description="Learn robust Franka Panda motions from videos of a human hand.",
    )
    parser.add_argument("--version", action="version", version=f"dexlfd {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, module in COMMANDS.items():
        mod = importlib.import_module(f"dexlfd._commands.{module}")
        p = mod.add_parser(sub, name)
        p.add_argument(
            "-v", "--verbose", action="count", default=0, help="more output; -v shows tracebacks"
        )
        p.add_argument("-q", "--quiet", action="store_true", help="only warnings and errors")
        p.set_defaults(_run=mod.run)
    return parser


def _setup_logging(verbose: int, quiet: bool) -> None:
    level = logging.WARNING if quiet else (logging.DEBUG if verbose >= 2 else logging.INFO)
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("%(levelname).1s %(name)s: %(message)s"))
    root = logging.getLogger("dexlfd")
    root.handlers[:] = [handler]
    root.setLevel(level)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the process exit code."""
    parser = _build_parser()
    args = parser.parse_args(argv)
    _setup_logging(args.verbose, args.quiet)
    try:
        return int(args._run(args) or 0)
    except DexlfdError as exc:
        if args.verbose:
            logger.exception("%s", exc)
        else:
            sys.stderr.write(f"dexlfd {args.command}: error: {exc}\n")
        return 1
    except KeyboardInterrupt:
        sys.stderr.write(f"dexlfd {args.command}: interrupted; finished outputs are kept\n")
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
