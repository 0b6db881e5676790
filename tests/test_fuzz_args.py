"""Property/fuzz tests of the argument parsers and the output policy.

Properties: a numeric flag either parses to a value inside its documented range or is a
usage error (exit 2) - never a traceback, NaN or an unbounded value; random token lists never
raise anything but SystemExit; an output accepted by the policy is never an input, and two
accepted outputs never name the same file; flag translation leaves paths and other words
alone.
"""

from __future__ import annotations

import contextlib
import io
import math
import os
from pathlib import Path

import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from dexlfd._commands._common import MAX_SEED, bounded_float, bounded_int
from dexlfd._commands._outputs import DIR, check_outputs
from dexlfd.cli import _build_parser, error_text
from dexlfd.errors import InvalidInput
from dexlfd.plan.config import MAX_MOTION_S

FUZZ = settings(
    max_examples=100,
    deadline=None,
    derandomize=True,
    database=None,
    phases=[Phase.explicit, Phase.generate],
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
PARSER = _build_parser()

# (command, positional arguments, flag, low, high): the documented range of each flag
BOUNDED = [
    ("simulate", ["p.npz", "-o", "r.npz"], "--torque-delay-ticks", 0, 100),
    ("simulate", ["p.npz", "-o", "r.npz"], "--payload-kg", 0.0, 3.0),
    ("simulate", ["p.npz", "-o", "r.npz"], "--model-error", 0.0, 0.99),
    ("simulate", ["p.npz", "-o", "r.npz"], "--seed", 0, MAX_SEED),
    ("teleop", ["v.mp4"], "--render-width-px", 16, 640),
    ("teleop", ["v.mp4"], "--render-height-px", 16, 480),
    ("teleop", ["v.mp4"], "--reach-radius-m", 0.0, 0.855),
    ("teleop", ["v.mp4"], "--scale", 0.0, 10.0),
    ("learn", ["d.npz", "-o", "m.npz"], "--k", 1, 50),
    ("learn", ["d.npz", "-o", "m.npz"], "--window", 1, 10_000),
    ("learn", ["d.npz", "-o", "m.npz"], "--n-query", 2, 100_000),
    ("learn", ["d.npz", "-o", "m.npz"], "--band-fraction", 0.0, 1.0),
    ("learn", ["d.npz", "-o", "m.npz"], "--max-gap-s", 0.0, 60.0),
    ("plan", ["m.npz", "-o", "p.npz"], "--duration-s", 0.0, MAX_MOTION_S),
    ("plan", ["m.npz", "-o", "p.npz"], "--rate-hz", 0.0, 10_000.0),
    ("plan", ["m.npz", "-o", "p.npz"], "--margin-m", 0.0, 1.0),
    ("demo", [], "--workers", 1, 64),
    ("experiment", ["payload"], "--workers", 1, 64),
    ("experiment", ["payload"], "--duration-s", 0.0, 60.0),
    ("synth", ["-o", "d"], "-n", 1, 1000),
]

NUMBERS = st.one_of(
    st.integers(-(2**70), 2**70).map(str),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.sampled_from(["nan", "inf", "-inf", "1e9", "1e400", "0x10", "1_000", " 5", "", "٣", "0"]),
    st.text(max_size=12),
)


def _parse(argv: list[str]):
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        return PARSER.parse_args(argv)


@FUZZ
@given(case=st.sampled_from(BOUNDED), text=NUMBERS)
def test_numeric_flags_parse_inside_their_range_or_exit_2(case, text: str) -> None:
    command, positional, flag, lo, hi = case
    try:
        args = _parse([command, *positional, f"{flag}={text}"])
    except SystemExit as exc:
        assert exc.code == 2
        return
    dest = next(a.dest for a in PARSER._subparsers._group_actions[0].choices[command]._actions
                if flag in a.option_strings)  # type: ignore[union-attr]  # fmt: skip
    value = getattr(args, dest)
    if value == "auto":  # --k and --window: the word that lets learning choose
        return
    assert isinstance(value, int | float) and math.isfinite(value)
    assert lo <= value <= hi


TOKENS = st.sampled_from(
    ["simulate", "teleop", "learn", "plan", "demo", "synth", "export", "record", "experiment",
     "payload", "-o", "--output", "x.npz", "--seed", "-1", "0", "nan", "--k", "--window",
     "--workers", "--torque-delay", "--video", "--format", "csv", "--fresh", "-v", "-q",
     "--hand", "left", "--", "-", "--plot", "1e999", "--render-width-px", "2000"]
)  # fmt: skip


@FUZZ
@given(argv=st.lists(st.one_of(TOKENS, st.text(max_size=6)), max_size=8))
def test_random_command_lines_are_parsed_or_refused_cleanly(argv: list[str]) -> None:
    with contextlib.suppress(SystemExit):
        _parse(argv)


@FUZZ
@given(lo=st.integers(-1000, 1000), width=st.integers(0, 1000), value=st.integers(-3000, 3000))
def test_bounded_int_accepts_exactly_its_range(lo: int, width: int, value: int) -> None:
    import argparse

    parse = bounded_int(lo, lo + width)
    if lo <= value <= lo + width:
        assert parse(str(value)) == value
    else:
        with pytest.raises(argparse.ArgumentTypeError, match=f"{lo}..{lo + width}"):
            parse(str(value))


@FUZZ
@given(value=st.floats(allow_nan=True, allow_infinity=True), lo_open=st.booleans())
def test_bounded_float_accepts_exactly_its_range(value: float, lo_open: bool) -> None:
    import argparse

    parse = bounded_float(0.0, 3.0, lo_open=lo_open)
    inside = (value > 0.0 if lo_open else value >= 0.0) and value <= 3.0
    if inside:
        assert parse(repr(value)) == value
    else:
        with pytest.raises(argparse.ArgumentTypeError, match="expected a number in"):
            parse(repr(value))


@FUZZ
@given(
    picks=st.lists(st.tuples(st.integers(0, 7), st.sampled_from([".npz", ".mp4", None, DIR])),
                   min_size=1, max_size=4),
    inputs=st.lists(st.integers(0, 7), max_size=3),
)  # fmt: skip
def test_accepted_outputs_are_never_inputs_and_never_collide(tmp_path: Path, picks, inputs):
    # a pool of names: files, a symlink and a hard link to the same file, a folder, a link
    # to the folder, and names that do not exist yet
    root = tmp_path / "pool"
    if not root.exists():
        root.mkdir()
        (root / "a.npz").write_bytes(b"a")
        (root / "sym.npz").symlink_to(root / "a.npz")
        os.link(root / "a.npz", root / "hard.npz")
        (root / "v.mp4").write_bytes(b"v")
        (root / "dir").mkdir()
        (root / "dirlink").symlink_to(root / "dir")
    pool = [root / "a.npz", root / "sym.npz", root / "hard.npz", root / "v.mp4",
            root / "new.npz", root / "dir" / "new.npz", root / "dirlink" / "new.npz",
            root / "figs"]  # fmt: skip
    outputs = [(f"--out{i}", pool[j], kind) for i, (j, kind) in enumerate(picks)]
    sources = [pool[j] for j in inputs]
    try:
        got = check_outputs(outputs, inputs=sources)
    except InvalidInput as exc:
        assert str(exc).startswith("--out")  # names the flag
        return
    real = [os.path.realpath(p) for p in got if p is not None]
    assert len(set(real)) == len(real)
    for out in got:
        assert out is not None
        for src in sources:
            assert not (out.exists() and src.exists() and os.path.samefile(out, src))


FIELDS = {"window": "--window", "n_components": "--k", "payload_kg": "--payload-kg"}


@FUZZ
@given(
    words=st.lists(st.sampled_from(["must", "be", "got", "0", "windows", "my_window", "K",
                                    "payload", "(", ")", ":", "window_s"]), max_size=10),
    path=st.sampled_from(["/data/window.npz", "runs/n_components/x.npz", "payload_kg-1.csv"]),
    param=st.sampled_from([None, "window", "n_components", "payload_kg", "band"]),
)  # fmt: skip
def test_an_error_names_only_the_flag_of_its_param(words: list[str], path: str, param) -> None:
    """The words of a message are never rewritten: a known param puts its flag first."""
    message = f"{path}: " + " ".join(words)
    text = error_text(InvalidInput(message, param=param), FIELDS)
    assert text == (f"{FIELDS[param]}: {message}" if param in FIELDS else message)
