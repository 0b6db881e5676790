"""The ``dexlfd`` command: one subcommand per pipeline stage, plus ``demo``.

Examples
--------
    dexlfd demo -o out/
    dexlfd learn demos/*.npz -o model.npz --plot figures/

Each subcommand lives in ``dexlfd/_commands/<name>.py`` with ``add_parser`` and
``run``; this module only sets up logging, dispatches and maps errors to exit
codes (0 ok, 1 a :class:`~dexlfd.errors.DexlfdError`, 2 usage, 130 interrupted by Ctrl-C,
143 / 129 stopped by SIGTERM / SIGHUP: :mod:`dexlfd._signals` makes those two stop a run
the way Ctrl-C does, cleanups included).

The library names its own parameters in errors (``n_components (K) must be >= 1``); a
subcommand module's ``FLAGS`` maps those names to its flags, and :func:`speak_cli` rewrites
every :class:`~dexlfd.errors.DexlfdError` message with them (``--k must be >= 1``;
``overlay video out/o.mp4: ...`` -> ``--overlay out/o.mp4: ...``).
"""

from __future__ import annotations

import argparse
import errno
import importlib
import logging
import re
import sys
from collections.abc import Mapping, Sequence
from typing import Any, NoReturn

from dexlfd import __version__
from dexlfd._signals import describe, exit_code, stop_signals_as_interrupts
from dexlfd.errors import DexlfdError, broken_import, import_culprit

__all__ = ["main", "speak_cli"]

logger = logging.getLogger("dexlfd")

# subcommand name -> module in dexlfd._commands (imported lazily: heavy deps stay unloaded)
COMMANDS: dict[str, str] = {
    "demo": "demo",
    "teach": "teach",
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


class _ExactParser(argparse.ArgumentParser):
    """An argument parser that takes flags only by their full names.

    argparse's default abbreviation matching lets a typo pass as another flag
    (``plan --place ...`` read as ``--place-surface-m``); every command refuses it instead.
    """

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs["allow_abbrev"] = False
        super().__init__(*args, **kwargs)

    def error(self, message: str) -> NoReturn:
        """One line (exit 2): what is wrong and where the flags are listed, no usage block.

        A bad choice (``--controller pid``) names the choices already; the usage of a
        subcommand with 30 flags buried that line.
        """
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _build_parser(only: str | None = None) -> argparse.ArgumentParser:
    """The ``dexlfd`` parser; with ``only``, that subcommand's flags alone are built.

    Building a subcommand's flags imports what their choices and ranges come from (the
    controllers, the capture configuration), about a second in all: ``main`` builds the
    one it runs, and every other subcommand is a name with its one-line summary, so
    ``dexlfd --help`` and usage errors still list them all. ``only=None`` builds all.
    """
    parser = _ExactParser(
        prog="dexlfd",
        description="Learn robust Franka Panda motions from videos of a human hand.",
    )
    parser.add_argument("--version", action="version", version=f"dexlfd {__version__}")
    sub = parser.add_subparsers(
        dest="command", metavar="COMMAND", required=True, parser_class=_ExactParser
    )
    for name, module in COMMANDS.items():
        mod = importlib.import_module(f"dexlfd._commands.{module}")
        if only is not None and name != only:
            sub.add_parser(name, help=mod.HELP)
            continue
        p = mod.add_parser(sub, name)
        if not p.description:  # `dexlfd NAME --help` opens with what it does
            p.description = _description(mod)
        p.add_argument(
            "-v", "--verbose", action="count", default=0, help="more output; -v shows tracebacks"
        )
        p.add_argument("-q", "--quiet", action="store_true", help="only warnings and errors")
        p.set_defaults(_run=mod.run, _flags=getattr(mod, "FLAGS", {}))
    return parser


def _description(mod: Any) -> str:
    """A subcommand's description: its module's ``DESCRIPTION``, else its one-line help."""
    text = getattr(mod, "DESCRIPTION", None) or str(mod.HELP)
    return text[0].upper() + text[1:] + ("" if text.endswith(".") else ".")


def _command_in(argv: Sequence[str]) -> str:
    """The subcommand ``argv`` names (its first word that is not a flag), else ``""``.

    The top-level parser has no flag that takes a value, so that word is the command.
    """
    word = next((a for a in argv if not a.startswith("-")), "")
    return word if word in COMMANDS else ""


def speak_cli(message: str, flags: Mapping[str, str]) -> str:
    """``message`` with the library's parameter names replaced by the command's flags.

    ``flags`` maps a config field (``"n_components"``) to a flag (``"--k"``). A field is
    replaced where it stands as a name: optionally qualified by its class
    (``LoopConfig.torque_delay``) and followed by a symbol in parentheses (``(K)``), never
    inside a path or a longer name.
    """
    for field in sorted(flags, key=len, reverse=True):
        pattern = (
            rf"(?<![\w/.\\-])(?:[A-Z]\w*\.)?{re.escape(field)}(?:\s\(\w+\))?"
            rf"(?![\w/\\-]|\.\w)"
        )
        message = re.sub(pattern, flags[field], message)
    return message


class _CliFormatter(logging.Formatter):
    """Warnings with the library's parameter names replaced by the command's flags.

    Only warnings and errors give advice ("use euler_mode palm"); info lines report
    values and keep the library's words. Log lines are English sentences, so only
    identifier-like names are replaced there (``euler_mode``, ``LoopConfig.x``: a key with
    ``_`` or ``.``); plain words such as ``goal`` or ``start`` stay words. Errors
    (:func:`main`) keep the full rewrite.
    """

    def __init__(self, flags: Mapping[str, str]) -> None:
        super().__init__("%(levelname).1s %(name)s: %(message)s")
        self.flags = {k: v for k, v in flags.items() if "_" in k or "." in k}

    def format(self, record: logging.LogRecord) -> str:
        text = super().format(record)
        return speak_cli(text, self.flags) if record.levelno >= logging.WARNING else text


def _setup_logging(verbose: int, quiet: bool, flags: Mapping[str, str] | None = None) -> None:
    level = logging.WARNING if quiet else (logging.DEBUG if verbose >= 2 else logging.INFO)
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(_CliFormatter(flags or {}))
    root = logging.getLogger("dexlfd")
    root.handlers[:] = [handler]
    root.setLevel(level)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the process exit code."""
    argv = sys.argv[1:] if argv is None else list(argv)
    with stop_signals_as_interrupts():
        try:
            return _main(argv)
        except KeyboardInterrupt as exc:  # while its parser was built (nothing written yet)
            command = _command_in(argv)
            sys.stderr.write(f"dexlfd{' ' + command if command else ''}: {describe(exc)}\n")
            return exit_code(exc)


def _main(argv: list[str]) -> int:
    # building a command's flags imports its stage (a second or more on a busy machine)
    parser = _build_parser(only=_command_in(argv))
    args = parser.parse_args(argv)
    _setup_logging(args.verbose, args.quiet, args._flags)
    from dexlfd._commands._outputs import guard_run

    try:
        with guard_run(args):  # no output may be a file any flag names
            return int(args._run(args) or 0)
    except DexlfdError as exc:
        text = speak_cli(str(exc), args._flags)
        if args.verbose:
            logger.exception("%s", text)
        else:
            sys.stderr.write(f"dexlfd {args.command}: error: {text}\n")
        return 1
    except KeyboardInterrupt as exc:
        sys.stderr.write(f"dexlfd {args.command}: {describe(exc)}; finished outputs are kept\n")
        return exit_code(exc)
    except ImportError as exc:
        # an installed dependency that no longer imports (e.g. OpenCV after a second cv2
        # distribution was removed): one line naming it; our own modules' errors are bugs
        if args.verbose or import_culprit(exc) in ("", "dexlfd"):
            raise
        sys.stderr.write(f"dexlfd {args.command}: error: {broken_import(exc)}\n")
        return 1
    except OSError as exc:
        # a path the file system refuses by its form (too long, a name or a loop it cannot
        # resolve): a user's mistake wherever it is first touched, said in one line
        if exc.errno not in _PATH_ERRORS or args.verbose:
            raise
        sys.stderr.write(
            f"dexlfd {args.command}: error: {exc.filename}: {exc.strerror} "
            f"(at most {_NAME_MAX} bytes per file or folder name)\n"
        )
        return 1


_NAME_MAX = 255  # bytes of one path component on Linux/macOS file systems
_PATH_ERRORS = (errno.ENAMETOOLONG, errno.ELOOP)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
