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

Flags that set a config field are generated from the field (:mod:`dexlfd._commands._fields`),
so a value out of range is a one-line usage error naming the flag. An
:class:`~dexlfd.errors.InvalidInput` that names the setting at fault (its ``param``) is
shown with that setting's flag, which the parser knows; older flag spellings still
work and warn once; ``--config FILE`` (TOML, or YAML with PyYAML) sets flags from a file,
flags on the command line winning.
"""

from __future__ import annotations

import argparse
import errno
import importlib
import logging
import os
import sys
from collections.abc import Sequence
from typing import Any, NoReturn

from dexlfd import __version__
from dexlfd._signals import describe, exit_code, stop_signals_as_interrupts
from dexlfd.errors import DexlfdError, broken_import, import_culprit

__all__ = ["error_text", "main", "param_flags"]

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
        p.add_argument(
            "--config", metavar="FILE",
            help="read flags from a TOML file (.yaml/.yml: YAML, needs PyYAML): keys are flag "
            "names without -- (margin-m = 0.05, pick = [0.5, -0.2, 0.12]), optionally under "
            f"[{name}]; flags on the command line win",
        )  # fmt: skip
        p.set_defaults(_run=mod.run, _params=param_flags(p))
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


def _subparser(parser: argparse.ArgumentParser, command: str) -> argparse.ArgumentParser:
    """The parser of ``command`` inside the ``dexlfd`` parser."""
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return sub.choices[command]


def _with_config(sub: argparse.ArgumentParser, argv: list[str], command: str) -> list[str]:
    """``argv`` with the flags of its ``--config FILE`` put first (the command line wins)."""
    from dexlfd._commands._fields import config_argv

    path = None
    for i, tok in enumerate(argv):
        if tok == "--config" and i + 1 < len(argv):
            path = argv[i + 1]
        elif tok.startswith("--config="):
            path = tok.split("=", 1)[1]
    if path is None:
        return argv
    try:
        tokens = config_argv(sub, path, command)
    except ValueError as exc:
        sub.error(f"--config {path}: {exc}")
    at = argv.index(command) + 1
    return [*argv[:at], *tokens, *argv[at:]]


def param_flags(parser: argparse.ArgumentParser) -> dict[str, str]:
    """``{setting: flag}`` of a command's parser: each flag's ``args`` name and config field."""
    out: dict[str, str] = {}
    for action in parser._actions:
        if action.option_strings:
            flag = max(action.option_strings, key=len)
            out.setdefault(action.dest, flag)
            if getattr(action, "param", None):
                out[action.param] = flag  # type: ignore[attr-defined]
    return out


def error_text(exc: BaseException, flags: dict[str, str]) -> str:
    """The error's text, its ``param`` (if any) shown as the flag that sets it.

    ``flags`` is :func:`param_flags` of the command's parser (``args._params``).
    """
    text = str(exc)
    param = getattr(exc, "param", None)
    flag = flags.get(param) if param else None
    if flag is None or param is None:
        return text
    head, dot, rest = text.partition(".")  # "PlanConfig.margin must ..." -> "margin must ..."
    if dot and head.isidentifier() and head[:1].isupper() and rest.startswith(param):
        text = rest
    if text.startswith(param) and text[len(param) : len(param) + 1] in ("", " ", ":"):
        return flag + text[len(param) :]
    return f"{flag}: {text}"


def _setup_logging(verbose: int, quiet: bool) -> None:
    level = logging.WARNING if quiet else (logging.DEBUG if verbose >= 2 else logging.INFO)
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("%(levelname).1s %(name)s: %(message)s"))
    root = logging.getLogger("dexlfd")
    root.handlers[:] = [handler]
    root.setLevel(level)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the process exit code."""
    argv = sys.argv[1:] if argv is None else list(argv)
    _one_blas_thread()
    with stop_signals_as_interrupts():
        try:
            return _main(argv)
        except KeyboardInterrupt as exc:  # while its parser was built (nothing written yet)
            command = _command_in(argv)
            _say(f"dexlfd{' ' + command if command else ''}: {describe(exc)}\n")
            return exit_code(exc)


def run() -> NoReturn:
    """The ``dexlfd`` script: :func:`main`, then the exit of :func:`dexlfd._exit.exit_process`."""
    from dexlfd._exit import exit_process

    exit_process(main())


def _one_blas_thread() -> None:
    """OpenBLAS on one thread (``OPENBLAS_NUM_THREADS=1``) unless the user chose otherwise.

    Every matrix dexlfd multiplies or factors is small (the arm's 7x7, a DMP's 6x6
    transition, a GMM of a few dimensions), where OpenBLAS's worker threads cost more than
    they give; and beside other jobs its threads wait for each other for whole time
    slices: ``dexlfd plan`` took 170 s instead of 71 s (the same 4 s of CPU) on two cores
    busy with other work, and two plans run at once on a loaded machine spun for 17
    minutes. Set before NumPy loads (the commands import it lazily); the stages' worker
    processes inherit it.
    """
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def _interruptible(args: argparse.Namespace) -> int:
    """``args._run(args)``; an error that a Ctrl-C or stop signal caused is that interrupt.

    A signal's exception may surface wrapped: raised while a class was created, Python
    3.11 reports ``RuntimeError: Error calling __set_name__`` with the interrupt as its
    cause, and code that re-raises a failure as its own error keeps it as context.
    """
    try:
        return int(args._run(args) or 0)
    except Exception as exc:
        seen: set[int] = set()
        link: BaseException | None = exc
        while link is not None and id(link) not in seen:
            if isinstance(link, KeyboardInterrupt):
                raise link from exc
            seen.add(id(link))
            link = link.__cause__ or link.__context__
        raise


def _say(line: str) -> None:
    r"""Write ``line`` to stderr; a file name's undecodable bytes shown escaped (``\udcff``)."""
    sys.stderr.write(line.encode("utf-8", "backslashreplace").decode("utf-8"))


def _main(argv: list[str]) -> int:
    # building a command's flags imports its stage (a second or more on a busy machine)
    command = _command_in(argv)
    parser = _build_parser(only=command)
    sub = _subparser(parser, command) if command else parser
    if command:
        argv = _with_config(sub, argv, command)
    args = parser.parse_args(argv)
    _setup_logging(args.verbose, args.quiet)
    from dexlfd._commands._fields import aliases_in

    for old, new in aliases_in(sub, argv).items():
        logger.warning("%s is an old spelling of %s, which replaces it", old, new)
    from tqdm.contrib.logging import logging_redirect_tqdm

    from dexlfd._commands._outputs import failed_run, guard_run

    try:  # log lines go above a progress bar, not through it
        with logging_redirect_tqdm([logging.getLogger("dexlfd")]), guard_run(args):
            code = int(_interruptible(args))
            if code:
                failed_run()
            return code
    except DexlfdError as exc:
        text = error_text(exc, args._params)
        if args.verbose:
            logger.exception("%s", text)
        else:
            _say(f"dexlfd {args.command}: error: {text}\n")
        return 1
    except KeyboardInterrupt as exc:
        _say(f"dexlfd {args.command}: {describe(exc)}; finished outputs are kept\n")
        return exit_code(exc)
    except ImportError as exc:
        # an installed dependency that no longer imports (e.g. OpenCV after a second cv2
        # distribution was removed): one line naming it; our own modules' errors are bugs
        if args.verbose or import_culprit(exc) in ("", "dexlfd"):
            raise
        _say(f"dexlfd {args.command}: error: {broken_import(exc)}\n")
        return 1
    except OSError as exc:
        # a path the file system refuses by its form (too long, a name or a loop it cannot
        # resolve): a user's mistake wherever it is first touched, said in one line
        if exc.errno not in _PATH_ERRORS or args.verbose:
            raise
        _say(
            f"dexlfd {args.command}: error: {exc.filename}: {exc.strerror} "
            f"(at most {_NAME_MAX} bytes per file or folder name)\n"
        )
        return 1


_NAME_MAX = 255  # bytes of one path component on Linux/macOS file systems
_PATH_ERRORS = (errno.ENAMETOOLONG, errno.ELOOP)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
