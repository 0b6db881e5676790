"""Flags generated from config fields, old flag spellings, and ``--config FILE``.

A config dataclass states each setting once (:func:`dexlfd._params.param`: name, unit,
default, range, help); :func:`add_params` turns those fields into argparse flags with
that range check and ``--help`` text, so a bad value is a one-line usage error naming
the flag, and :func:`param_values` reads them back as the config's keyword arguments.
:func:`alias` keeps an older spelling of a flag working (the command line warns once);
:func:`config_argv` turns a TOML (or, with PyYAML, YAML) file into the flags it sets.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from dexlfd._params import Param, params_of

__all__ = [
    "add_params",
    "alias",
    "aliases_in",
    "config_argv",
    "metres_hint",
    "param_type",
    "param_values",
]

_HIDDEN = frozenset({"--config", "--help", "-h", "--version"})


def metres_hint(values: Iterable[float], inside: Callable[[float], bool] | None = None) -> str:
    """``"; ... looks like millimetres"`` when ``values`` read as metres only divided by 1000.

    ``inside`` accepts a value in metres (default: within 5 m of the base); the hint is
    given when some value is not inside and every value / 1000 is.
    """
    check = inside or (lambda v: abs(v) <= 5.0)
    vals = [float(v) for v in values]
    if vals and not all(check(v) for v in vals) and all(check(v / 1000.0) for v in vals):
        return "; looks like millimetres: positions and lengths are in metres"
    return ""


def param_type(meta: Param) -> Callable[[str], Any]:
    """Argparse type of a :class:`Param`: a number in its range, else a one-line error."""
    noun = "an integer" if meta.integer else "a number"

    def parse(text: str) -> Any:
        if text.strip() in meta.words:
            return text.strip()
        try:
            value: Any = int(text) if meta.integer else float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"expected {noun} in {meta.accepted()}, got {text!r}"
            ) from None
        if not meta.inside(float(value)):
            hint = metres_hint([value], meta.inside) if meta.unit == "m" else ""
            raise argparse.ArgumentTypeError(
                f"expected {noun} in {meta.accepted()}, got {text.strip()}{hint}"
            )
        return value

    parse.__name__ = noun.split()[-1]  # argparse's "invalid <name> value"
    return parse


def alias(parser: Any, action: argparse.Action, *old: str) -> argparse.Action:
    """Accept the older spellings ``old`` of ``action``'s flag (not shown in ``--help``).

    The command line warns once per old spelling used (:func:`aliases_in`).
    """
    for flag in old:
        parser._option_string_actions[flag] = action
    action.deprecated_aliases = (*getattr(action, "deprecated_aliases", ()), *old)  # type: ignore[attr-defined]
    return action


def aliases_in(parser: argparse.ArgumentParser, argv: Sequence[str]) -> dict[str, str]:
    """``{old spelling: flag}`` for every deprecated spelling ``argv`` uses."""
    old = {
        name: action.option_strings[-1]
        for action in parser._actions
        for name in getattr(action, "deprecated_aliases", ())
    }
    names = (tok.split("=", 1)[0] for tok in argv)
    return {name: old[name] for name in names if name in old}


def add_params(
    parser: Any,
    cls: Any,
    names: Sequence[str],
    *,
    defaults: Mapping[str, Any] | None = None,
    notes: Mapping[str, str] | None = None,
    dests: Mapping[str, str] | None = None,
) -> dict[str, argparse.Action]:
    """Add a flag for each field ``names`` of the config class ``cls``.

    Flag, type (range check), help and default come from the field's :class:`Param`
    and default; ``defaults`` overrides a default (the command's own, e.g. a study's),
    ``notes`` adds to a help text, ``dests`` sets an ``args`` attribute. Returns the
    actions by field name.
    """
    metas = params_of(cls)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    actions: dict[str, argparse.Action] = {}
    for name in names:
        meta = metas[name]
        default = (defaults or {}).get(name, fields[name].default)
        text = f"{meta.help}; {meta.accepted()}"
        if notes and name in notes:
            text += f"; {notes[name]}"
        if default is not None:
            text += " (default: %(default)s)"
        kwargs: dict[str, Any] = {"type": param_type(meta), "default": default, "help": text}
        if dests and name in dests:
            kwargs["dest"] = dests[name]
        action = parser.add_argument(meta.flag_for(name), **kwargs)
        action.param = name  # errors naming the field name its flag
        action.param_meta = meta  # what the flag states and checks
        if meta.aliases:
            alias(parser, action, *meta.aliases)
        actions[name] = action
    return actions


def param_values(
    args: argparse.Namespace, actions: Mapping[str, argparse.Action]
) -> dict[str, Any]:
    """``{field: value}`` of the flags :func:`add_params` added (the config's kwargs)."""
    return {name: getattr(args, action.dest) for name, action in actions.items()}


def _load(path: Path) -> dict[str, Any]:
    """The settings of a TOML or YAML file (a mapping), or ValueError with the reason."""
    if path.suffix.lower() in (".yaml", ".yml"):
        try:
            import yaml  # type: ignore[import-untyped]
        except ImportError:
            raise ValueError("YAML needs PyYAML, which is not installed; use a TOML file") from None
        try:
            data = yaml.safe_load(path.read_text(encoding="utf-8"))
        except yaml.YAMLError as exc:
            raise ValueError(f"not valid YAML ({str(exc).splitlines()[0]})") from None
    else:
        import tomllib

        try:
            data = tomllib.loads(path.read_text(encoding="utf-8"))
        except tomllib.TOMLDecodeError as exc:
            raise ValueError(f"not valid TOML ({exc})") from None
    if not isinstance(data, dict):
        raise ValueError("expected a table of settings (key = value)")
    return data


def _text(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float) and math.isfinite(value):
        return repr(value)
    if isinstance(value, list | tuple):
        return ",".join(_text(v) for v in value)
    return str(value)


def config_argv(parser: argparse.ArgumentParser, path: str, command: str) -> list[str]:
    """The flags a ``--config`` file sets, as command-line tokens.

    Keys are flag names without ``--`` (``margin-m = 0.05``; ``_`` for ``-`` also
    works), optionally under a table named after the command (``[plan]``); a list is
    comma-separated (``pick = [0.5, -0.2, 0.12]``) or, for a repeatable flag, one flag
    per item. Raises ValueError naming the key when it is no flag of the command.
    """
    try:
        data = _load(Path(path))
    except OSError as exc:
        raise ValueError(exc.strerror or str(exc)) from None
    if isinstance(data.get(command), dict):
        data = data[command]
    tokens: list[str] = []
    for key, value in data.items():
        flag = "--" + str(key).replace("_", "-")
        action = parser._option_string_actions.get(flag)
        if action is None or flag in _HIDDEN:
            raise ValueError(f"{key!r} is not a flag of dexlfd {command}")
        if action.nargs == 0:  # a switch: true sets it, false leaves it off
            if not isinstance(value, bool):
                raise ValueError(f"{key} = {value!r}: expected true or false")
            tokens += [flag] if value else []
        elif isinstance(value, list) and isinstance(action, argparse._AppendAction):
            tokens += [f"{flag}={_text(item)}" for item in value]
        elif isinstance(value, list) and action.nargs in ("+", "*"):
            tokens += [flag, *(_text(v) for v in value)]
        else:  # flag=value: a value starting with - is not read as a flag
            tokens.append(f"{flag}={_text(value)}")
    return tokens
