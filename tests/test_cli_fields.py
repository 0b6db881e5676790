"""Flags generated from config fields: range, default, old spellings, ``--config FILE``.

Properties: every flag that sets a config field refuses a value just outside the field's
range with one line naming the flag, and its default is inside that range; the config
itself refuses the same value naming the field; an old spelling parses to the same
value as the new one and warns once; a TOML (or YAML) file gives the same settings as the
flags it holds; a bad choice is one line; a position in millimetres gets a unit hint.
"""

from __future__ import annotations

import argparse
import dataclasses
import logging
import sys
from pathlib import Path
from typing import Any

import pytest

from dexlfd._commands._fields import param_type
from dexlfd._params import Param, params_of
from dexlfd.cli import COMMANDS, _build_parser, _subparser, _with_config, main
from dexlfd.errors import InvalidInput

PARSER = _build_parser()


def _generated() -> list[tuple[str, argparse.Action, Param]]:
    """(command, action, param) of every flag generated from a config field."""
    out = []
    for command in COMMANDS:
        for action in _subparser(PARSER, command)._actions:
            meta = getattr(action, "param_meta", None)
            if meta is not None:
                out.append((command, action, meta))
    return out


GENERATED = _generated()


def _outside(meta: Param) -> list[float]:
    """Values just outside the range (none where it is unbounded)."""
    step = 1 if meta.integer else 1e-6
    out = []
    if meta.lo is not None:
        out.append(meta.lo if meta.lo_open else meta.lo - step)
    if meta.hi is not None:
        out.append(meta.hi if meta.hi_open else meta.hi + step)
    return out


def test_the_generated_flags_cover_the_settings_the_commands_bounded_by_hand() -> None:
    flags = {(c, max(a.option_strings, key=len)) for c, a, _ in GENERATED}
    for expected in [("plan", "--margin-m"), ("plan", "--duration-s"), ("plan", "--dmp-basis"),
                     ("learn", "--k"), ("learn", "--max-gap-s"), ("simulate", "--payload-kg"),
                     ("simulate", "--torque-delay-ticks"), ("teleop", "--max-speed-mps"),
                     ("teleop", "--reach-radius-m"), ("record", "--fov-deg"),
                     ("calibrate", "--fov-deg"), ("record", "--max-hands"),
                     ("teleop", "--max-hands")]:  # fmt: skip
        assert expected in flags


@pytest.mark.parametrize(
    ("command", "action", "meta"),
    GENERATED,
    ids=[f"{c} {max(a.option_strings, key=len)}" for c, a, _ in GENERATED],
)
def test_a_value_outside_the_fields_range_is_one_line_naming_the_flag(
    command: str, action: argparse.Action, meta: Param, capsys
) -> None:
    flag = max(action.option_strings, key=len)
    assert meta.accepted() in (action.help or "")  # --help states the range
    if action.default is not None and action.default not in meta.words:
        assert meta.inside(float(action.default)), (flag, action.default)
        assert "default" in (action.help or "")
    for value in _outside(meta):
        with pytest.raises(SystemExit) as exc:
            main([command, f"{flag}={int(value) if meta.integer else value!r}"])
        assert exc.value.code == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and flag in err[0] and meta.accepted() in err[0], err


def test_every_config_refuses_what_its_flag_refuses() -> None:
    """The config's own check reads the same range: one source for both."""
    from dexlfd.control.loop_config import LoopConfig
    from dexlfd.learn import LearnConfig
    from dexlfd.plan import PlanConfig
    from dexlfd.plan.dmp_config import DmpConfig
    from dexlfd.plan.teleop import TeleopConfig
    from dexlfd.robot.plant import PlantConfig

    for cls in (LoopConfig, LearnConfig, PlanConfig, DmpConfig, TeleopConfig, PlantConfig):
        for name, meta in params_of(cls).items():
            default = next(f.default for f in dataclasses.fields(cls) if f.name == name)
            if default is not None and default not in meta.words:
                assert meta.inside(float(default)), (cls.__name__, name)
            for value in _outside(meta):
                with pytest.raises(InvalidInput, match=rf"^{cls.__name__}\.{name} must be") as e:
                    cls(**{name: int(value) if meta.integer else value})
                assert e.value.param == name


def test_an_old_spelling_parses_as_the_new_one_and_warns_once(tmp_path: Path, caplog) -> None:
    sub = _subparser(PARSER, "simulate")
    old = sub.parse_args(["p.npz", "-o", "r.npz", "--payload", "1.2", "--stop-force", "5"])
    new = sub.parse_args(["p.npz", "-o", "r.npz", "--payload-kg", "1.2", "--stop-force-n", "5"])
    assert vars(old) == vars(new)
    teleop = _subparser(PARSER, "teleop")
    for spelling in ("--max-speed", "--max-speed-mps"):
        assert teleop.parse_args(["v.mp4", spelling, "0.2"]).max_speed == 0.2
    # the old spelling is not listed in --help, the new one is
    help_text = sub.format_help()
    assert "--payload-kg" in help_text and "--payload " not in help_text
    model = tmp_path / "m.npz"
    model.write_bytes(b"refused before it is read")
    argv = ["plan", str(model), "--whole-motion", "--object-size", "0.05,0.05,0.06"]
    with caplog.at_level(logging.WARNING, logger="dexlfd"):
        assert main([*argv, "--object-size", "0.05,0.05,0.06", "-o", str(tmp_path / "p.npz")]) == 1
    warned = [r.getMessage() for r in caplog.records if "old spelling" in r.getMessage()]
    assert warned == ["--object-size is an old spelling of --object-size-m, which replaces it"]


PLAN_FLAGS = ["--margin-m", "0.05", "--pick", "0.5,-0.2,0.12", "--obstacle",
              "box:0.45,0,0.2,0.08,0.08,0.4", "--obstacle", "sphere:0.4,0.1,0.3,0.05",
              "--no-variance", "--dmp-k", "2", "--duration-s", "12"]  # fmt: skip
PLAN_TOML = """
margin-m = 0.05
pick = [0.5, -0.2, 0.12]
obstacle = ["box:0.45,0,0.2,0.08,0.08,0.4", "sphere:0.4,0.1,0.3,0.05"]
no-variance = true
coupling = "shaped"
dmp_k = 2
duration-s = 12
"""


def _parsed(argv: list[str]) -> dict[str, Any]:
    command = argv[0]
    args = PARSER.parse_args(_with_config(_subparser(PARSER, command), argv, command))
    return {k: v for k, v in vars(args).items() if k != "config"}


@pytest.mark.parametrize("table", [False, True])
def test_a_toml_config_gives_the_settings_its_flags_give(tmp_path: Path, table: bool) -> None:
    path = tmp_path / "plan.toml"
    path.write_text(("[plan]\n" if table else "") + PLAN_TOML)
    base = ["plan", "m.npz", "-o", "p.npz"]
    assert _parsed([*base, "--config", str(path)]) == _parsed([*base, *PLAN_FLAGS])
    # a flag on the command line wins over the file
    assert _parsed([*base, "--config", str(path), "--margin-m", "0.1"])["margin_m"] == 0.1


def test_a_yaml_config_needs_pyyaml_else_says_toml(tmp_path: Path, monkeypatch, capsys) -> None:
    path = tmp_path / "learn.yaml"
    path.write_text("k: 6\nwindow: 3\nexclude-outliers: true\n")
    base = ["learn", "d.npz", "-o", "m.npz"]
    pytest.importorskip("yaml")
    assert _parsed([*base, "--config", str(path)]) == _parsed(
        [*base, "--k", "6", "--window", "3", "--exclude-outliers"]
    )
    monkeypatch.setitem(sys.modules, "yaml", None)  # as if PyYAML were not installed
    with pytest.raises(SystemExit) as exc:
        main([*base, "--config", str(path)])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "YAML needs PyYAML" in err[0] and "use a TOML file" in err[0]


@pytest.mark.parametrize(
    ("text", "why"),
    [
        ("foo = 1\n", "'foo' is not a flag of dexlfd plan"),
        ("margin-m = 7\n", "--margin-m: expected a number in [0, 1] m, got 7"),
        ("no-variance = 3\n", "expected true or false"),
        ("margin-m = \n", "not valid TOML"),
        ("help = true\n", "'help' is not a flag"),
    ],
)
def test_a_bad_config_file_is_one_line(tmp_path: Path, capsys, text: str, why: str) -> None:
    path = tmp_path / "c.toml"
    path.write_text(text)
    with pytest.raises(SystemExit) as exc:
        main(["plan", "m.npz", "-o", "p.npz", "--config", str(path)])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and why in err[0], err


def test_a_bad_choice_is_one_line(capsys) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["simulate", "p.npz", "-o", "r.npz", "--controller", "foo"])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--controller" in err[0] and "'foo'" in err[0], err


@pytest.mark.parametrize("flag", ["--pick", "--place", "--goal", "--start"])
def test_a_position_in_millimetres_gets_a_unit_hint(tmp_path: Path, capsys, flag: str) -> None:
    model = tmp_path / "m.npz"
    model.write_bytes(b"refused before it is read")
    assert main(["plan", str(model), flag, "500,-200,120", "-o", str(tmp_path / "p.npz")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and flag in err[0], err
    assert "looks like millimetres: positions and lengths are in metres" in err[0]


@pytest.mark.parametrize(
    ("size", "hint"), [("50,50,60", True), ("5,0.05,0.06", False), ("0.05,0.05,0", False)]
)
def test_an_object_size_is_checked_as_a_size_not_a_position(
    tmp_path: Path, capsys, size: str, hint: bool
) -> None:
    model = tmp_path / "m.npz"
    model.write_bytes(b"refused before it is read")
    argv = ["plan", str(model), "--object-size-m", size, "-o", str(tmp_path / "p.npz")]
    assert main(argv) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "each size is in metres, in [0.005, 0.5]" in err[0], err
    assert "from the base" not in err[0]  # a size is no position
    assert ("looks like millimetres" in err[0]) == hint


def test_a_length_in_millimetres_gets_the_hint_and_metres_do_not() -> None:
    meta = Param("clearance", unit="m", lo=0.0, hi=1.0)
    with pytest.raises(argparse.ArgumentTypeError, match="looks like millimetres"):
        param_type(meta)("20")
    with pytest.raises(argparse.ArgumentTypeError) as exc:
        param_type(meta)("-0.5")
    assert "millimetres" not in str(exc.value)
    assert param_type(meta)("0.02") == 0.02


@pytest.mark.parametrize(
    ("command", "old", "new", "dest", "value"),
    [
        ("record", "--resize-width", "--resize-width-px", "resize_width", 320),
        ("teleop", "--resize-width", "--resize-width-px", "resize_width", 320),
        ("teleop", "--render-width", "--render-width-px", "render_width", 96),
        ("teleop", "--render-height", "--render-height-px", "render_height", 64),
    ],
)
def test_pixel_flags_end_in_px_and_the_old_spelling_warns(command, old, new, dest, value) -> None:
    from dexlfd._commands._fields import aliases_in

    sub = _subparser(PARSER, command)
    argv = ["v.mp4", "-o", "out.npz", old, str(value)]
    assert getattr(sub.parse_args(argv), dest) == value
    assert getattr(sub.parse_args(["v.mp4", "-o", "out.npz", new, str(value)]), dest) == value
    assert aliases_in(sub, argv) == {old: new}  # what the command line warns about
    help_text = sub.format_help()
    assert new in help_text and f"{old} " not in help_text
