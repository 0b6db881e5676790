"""Sweep every ``dexlfd`` subcommand with hostile and careless input and classify each outcome.

Each case runs the real command line (``dexlfd.cli.main``) in a child with bounded
resources: a wall-clock limit, ``RLIMIT_AS`` (3 GB by default) and, for the full-disk cases,
``RLIMIT_FSIZE``. dexlfd is imported once here and a child is forked per case (its compiled
kernels are inherited); Ctrl-C cases run in a fresh interpreter and get SIGINT after a delay.
Every case runs in a folder of its own, holding copies of its inputs, which are hashed before
and after. Classes (the first that applies, in this order):

- ``pickle ran``: a pickled object in an input was unpickled (a marker file appeared);
- ``lost file``: a file that existed before the run and that the run had no right to touch
  was changed or removed;
- ``unbounded memory``: the child hit the address-space limit (MemoryError, "Unable to
  allocate", std::bad_alloc, or killed while at the limit);
- ``hang``: the case's wall-clock limit passed (or Ctrl-C was not honoured in time);
- ``traceback``: a Python traceback, "Exception ignored", a fatal error or a signal death;
- ``leftover``: a new file that is not among the case's expected outputs (hidden ``.*``
  files always count), also in the child's own TMPDIR; a process of the run's group or
  session still running 2 s after the run ended (a worker, ffmpeg); a stray temporary of
  an earlier run (``Case.gone``) that a successful run did not remove;
- ``silent``: exit 0 on input the case calls nonsense, without a word (for cases that
  accept "a warning or a refusal", without a warning either);
- ``refused``: ordinary input that should have worked ended with a (clean) error;
- ``unclear``: an error without one ``dexlfd CMD: error: ...`` line naming the flag or
  file, an unexpected exit code, or exit 0 without the expected outputs;
- ``clean``: everything else (exit 0 with the expected files, or exit 1/2 with one line).

Usage::

    PYTHONPATH=src python benchmarks/sweep_inputs.py [-o OUT] [--filter REGEX] [--jobs N]

writes ``OUT/sweep.json`` (every case: argv, class, first stderr line) and
``OUT/table.txt`` (counts per class and subcommand), and prints both.
"""

from __future__ import annotations

import argparse
import atexit
import contextlib
import fnmatch
import gc
import hashlib
import io
import json
import os
import re
import resource
import shutil
import signal
import stat
import subprocess
import sys
import tempfile
import time
import zipfile
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parents[1]
GB = 1 << 30
LEDGER = ".dexlfd-outputs.json"  # dexlfd._commands._outputs.LEDGER
SIGINT_GRACE_S = 5.0  # Ctrl-C must end a command within this (on a machine not overloaded)
MAX_LOAD_FACTOR = 4.0  # limits stretch with the load, up to this many times


def load_factor() -> float:
    """How many times longer a case may take than on a machine whose cores are not shared.

    The 1-minute load average per core (this sweep's own jobs included), at least 1 and at
    most :data:`MAX_LOAD_FACTOR`: a 60 s simulation limit set for a quiet 2-core machine
    becomes 3 minutes at a load of 6 (other helpers' test runs beside the sweep).
    """
    per_core = os.getloadavg()[0] / (os.cpu_count() or 1)
    return min(MAX_LOAD_FACTOR, max(1.0, per_core))


NOBODY = 65534

CLASSES = (
    "clean",
    "pickle ran",
    "lost file",
    "unbounded memory",
    "hang",
    "traceback",
    "leftover",
    "silent",
    "refused",
    "unclear",
)
COMMANDS = (
    "calibrate", "record", "synth", "learn", "plan", "simulate", "experiment", "export",
    "teleop", "demo", "dexlfd",
)  # fmt: skip

# --------------------------------------------------------------------------- cases

Setup = Callable[[Path, "Fixtures"], None]


@dataclass
class Case:
    """One run (or a chain of runs) of the command line and what it should do.

    ``expect``: ``ok`` (exit 0 with ``outputs``), ``error`` (a one-line refusal; exit 0 is
    ``silent``), ``complain`` (a refusal or a warning line), ``any`` (either, cleanly).
    ``outputs`` are glob patterns (relative to the case folder; ``dir/**`` for a tree) of
    the new files a successful run may write; ``error_outputs`` those a failed or
    interrupted one may leave (a partial rollout). ``may_change`` are pre-existing files
    the run may replace (an existing output). ``needles``: one of them must be in the error
    line (the flag or the file); empty means any error line will do.
    """

    cid: str
    steps: list[list[str]]
    expect: str
    why: str
    setup: Setup | None = None
    outputs: tuple[str, ...] = ()
    error_outputs: tuple[str, ...] = ()
    may_change: tuple[str, ...] = ()
    needles: tuple[str, ...] = ()
    timeout: float = 60.0
    sigint_after: float | None = None
    fsize: int | None = None
    nobody: bool = False
    env: dict[str, str] = field(default_factory=dict)
    fresh: bool = False  # run in a new interpreter (subprocess) instead of a fork
    sigint_step: int = -1  # which step Ctrl-C interrupts (default: the last)
    stop_signal: int = signal.SIGINT  # what "Ctrl-C" sends: SIGINT, or SIGTERM / SIGHUP
    gone: tuple[str, ...] = ()  # files (of the setup) a successful run must have removed

    @property
    def command(self) -> str:
        first = self.steps[-1]
        return first[0] if first and first[0] in COMMANDS else "dexlfd"


@dataclass
class StepResult:
    rc: int | None  # None: killed at the time limit
    signal: int | None
    stderr: str
    seconds: float
    maxrss_mb: float
    sigint_late: bool = False
    limit_s: float = 0.0  # the wall-clock limit this step had (the case's, stretched by load)
    grace_s: float = SIGINT_GRACE_S  # the time it had to end after Ctrl-C (stretched too)
    left_running: tuple[str, ...] = ()  # processes of the step's group alive after it ended


@dataclass
class Outcome:
    case: Case
    cls: str
    detail: str
    results: list[StepResult]
    also: list[str]

    def as_json(self) -> dict[str, Any]:
        last = self.results[-1] if self.results else None
        return {
            "id": self.case.cid,
            "command": self.case.command,
            "argv": [" ".join(["dexlfd", *s]) for s in self.case.steps],
            "expect": self.case.expect,
            "why": self.case.why,
            "class": self.cls,
            "also": self.also,
            "detail": self.detail,
            "exit": last.rc if last else None,
            "signal": last.signal if last else None,
            "seconds": round(sum(r.seconds for r in self.results), 2),
            "max_rss_mb": round(max((r.maxrss_mb for r in self.results), default=0.0), 1),
            "first_stderr_line": _first_line(last.stderr) if last else "",
            "error_line": _error_line(last.stderr) if last else "",
        }


# --------------------------------------------------------------------------- fixtures


def _cli(argv: list[str]) -> None:
    """Run the CLI in this process (fixtures; warms numba kernels that children inherit)."""
    from dexlfd.cli import main

    rc = main([*argv, "-q"])
    if rc:
        raise RuntimeError(f"fixture command failed: dexlfd {' '.join(argv)}")


def _noise_video(path: Path, frames: int = 24, size: tuple[int, int] = (96, 64)) -> None:
    import cv2

    writer = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*"mp4v"), 12, size)
    rng = np.random.default_rng(0)
    for _ in range(frames):
        writer.write(rng.integers(0, 255, (size[1], size[0], 3), dtype=np.uint8))
    writer.release()


class Fixtures:
    """Valid files made with dexlfd's own writers, built on first use."""

    def __init__(self, root: Path, data: Path) -> None:
        self.root = root
        self.data = data
        self.root.mkdir(parents=True, exist_ok=True)
        self._made: dict[str, Path] = {}

    def path(self, key: str) -> Path:
        if key not in self._made:
            self._made[key] = getattr(self, f"_make_{key}")()
        return self._made[key]

    def copy(self, key: str, dest: Path) -> Path:
        src = self.path(key)
        if src.is_dir():
            shutil.copytree(src, dest)
        else:
            shutil.copyfile(src, dest)
        return dest

    def _make_demos(self) -> Path:
        out = self.root / "demos"
        _cli(["synth", "-n", "3", "--seed", "1", "-o", str(out)])
        return out

    def _make_demo(self) -> Path:
        return self.path("demos") / "demo_00.npz"

    def _make_model(self) -> Path:
        demos = sorted(self.path("demos").glob("demo_*.npz"))
        _cli(["learn", *map(str, demos), "--k", "3", "-o", str(self.root / "m.npz")])
        return self.root / "m.npz"

    def _make_plan(self) -> Path:
        out = self.root / "p.npz"
        _cli(["plan", str(self.path("model")), "--rate-hz", "100",
              "-o", str(out)])  # fmt: skip
        return out

    def _make_plan_obstacle(self) -> Path:
        out = self.root / "po.npz"
        _cli(["plan", str(self.path("model")), "--rate-hz", "100",
              "--obstacle", "box:0.45,0,0.2,0.1,0.1,0.1", "-o", str(out)])  # fmt: skip
        return out

    def _make_rollout(self) -> Path:
        out = self.root / "r.npz"
        _cli(["simulate", str(self.path("plan")), "--no-noise", "-o", str(out)])
        return out

    def _make_video(self) -> Path:
        out = self.root / "v.mp4"
        _noise_video(out)
        return out

    def _make_board(self) -> Path:
        out = self.root / "board.png"
        _cli(["calibrate", "--print-board", str(out), "--board", BOARD, "--dpi", "60"])
        return out

    def _make_bomb(self) -> Path:
        """A valid demonstration plus a 2.5 GB array of zeros that compresses to ~2.5 MB."""
        out = self.root / "bomb.npz"
        members = read_members(self.path("demo"))
        n = int(2.5 * GB) // 8
        with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED, compresslevel=1) as zf:
            for name, arr in members.items():
                zf.writestr(name + ".npy", _npy_bytes(arr))
            with zf.open("junk.npy", "w", force_zip64=True) as fh:
                head = io.BytesIO()
                np.lib.format.write_array_header_1_0(
                    head, {"descr": "<f8", "fortran_order": False, "shape": (n,)}
                )
                fh.write(head.getvalue())
                chunk = bytes(64 << 20)
                left = n * 8
                while left > 0:
                    fh.write(chunk[: min(left, len(chunk))])
                    left -= len(chunk)
        return out

    def _make_real_video(self) -> Path:
        path = self.data / "human_hand_video.mp4"
        if not path.exists():
            raise FileNotFoundError(path)
        return path


BOARD = "charuco:5x7,0.04,0.03"
BOARD_POSE = "0.5,0,0,0,0,0"

# --------------------------------------------------------------------------- npz surgery


def read_members(path: Path) -> dict[str, np.ndarray]:
    with np.load(path, allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


def _npy_bytes(arr: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.lib.format.write_array(buf, np.asanyarray(arr), allow_pickle=True)
    return buf.getvalue()


def write_members(path: Path, members: dict[str, np.ndarray | bytes]) -> None:
    """An .npz of ``members``; a ``bytes`` value is a raw ``.npy`` member (a crafted header)."""
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as zf:
        for name, value in members.items():
            data = value if isinstance(value, bytes) else _npy_bytes(value)
            zf.writestr(name if name.endswith(".npy") else name + ".npy", data)


def crafted_header(shape: tuple[int, ...], descr: str = "<f8", payload: int = 64) -> bytes:
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        buf, {"descr": descr, "fortran_order": False, "shape": shape}
    )
    return buf.getvalue() + bytes(payload)


class _Marker:
    """Unpickling this touches a marker file: proof that a pickle ran."""

    def __init__(self, marker: str) -> None:
        self.marker = marker

    def __reduce__(self) -> tuple[Any, tuple[str, str]]:
        return (open, (self.marker, "w"))


MARKER = "PICKLE_RAN"

MAIN_ARRAY = {"demonstration": "position", "model": "mean", "plan": "position",
              "rollout": "ee_position"}  # fmt: skip
POSITION = {"demonstration": "position", "model": "mean", "plan": "position",
            "rollout": "ee_position"}  # fmt: skip

Mutator = Callable[[dict[str, Any], Path], "dict[str, Any] | bytes | None"]


def _meta(m: dict[str, Any]) -> dict[str, Any]:
    return dict(json.loads(str(m["meta"])))


def _with_meta(m: dict[str, Any], meta: Any) -> dict[str, Any]:
    m = dict(m)
    m["meta"] = np.array(json.dumps(meta))
    return m


def _set(m: dict[str, Any], name: str, value: Any) -> dict[str, Any]:
    m = dict(m)
    m[name] = value
    return m


def _n(m: dict[str, Any]) -> int:
    return int(np.asarray(m["t"]).shape[0])


def _cut(m: dict[str, Any], k: int) -> dict[str, Any]:
    """Every per-sample array cut to its first ``k`` samples."""
    n = _n(m)
    return {
        name: (v[:k] if isinstance(v, np.ndarray) and v.ndim and v.shape[0] == n else v)
        for name, v in m.items()
    }


def _deep(depth: int) -> str:
    return "[" * depth + "]" * depth


def structural_mutators(kind: str) -> dict[str, tuple[str, Mutator]]:
    """name -> (expectation, mutator of the member dict) for one file kind."""
    pos = POSITION[kind]

    def scaled(name: str, factor: float) -> Mutator:
        return lambda m, d: _set(m, name, np.asarray(m[name], float) * factor)

    def nan_at(name: str, every: bool) -> Mutator:
        def f(m: dict[str, Any], d: Path) -> dict[str, Any]:
            a = np.array(m[name], dtype=float)
            if every:
                a[:] = np.nan
            else:
                a.flat[a.size // 2] = np.nan
            return _set(m, name, a)

        return f

    def t_as(values: Callable[[np.ndarray], np.ndarray]) -> Mutator:
        return lambda m, d: _set(m, "t", values(np.asarray(m["t"], float)))

    muts: dict[str, tuple[str, Mutator]] = {
        "no-meta": ("error", lambda m, d: {k: v for k, v in m.items() if k != "meta"}),
        "meta-not-json": ("error", lambda m, d: _set(m, "meta", np.array("{kind: plan,"))),
        "meta-list": ("error", lambda m, d: _with_meta(m, [1, 2, 3])),
        "meta-null": ("error", lambda m, d: _with_meta(m, None)),
        "meta-number-array": ("error", lambda m, d: _set(m, "meta", np.arange(3.0))),
        "meta-no-kind": (
            "error",
            lambda m, d: _with_meta(m, {k: v for k, v in _meta(m).items() if k != "kind"}),
        ),
        "meta-kind-int": ("error", lambda m, d: _with_meta(m, {**_meta(m), "kind": 7})),
        "meta-kind-other": (
            "error",
            lambda m, d: _with_meta(m, {**_meta(m), "kind": "plan" if kind != "plan" else "model"}),
        ),
        "meta-deep-nesting": (
            "any",
            lambda m, d: _set(
                m, "meta", np.array(json.dumps(_meta(m))[:-1] + ', "x": ' + _deep(100000) + "}")
            ),
        ),
        "meta-50MB-string": (
            "any",
            lambda m, d: _with_meta(m, {**_meta(m), "note": "x" * (50 << 20)}),
        ),
        # a file from a newer dexlfd: one past the version this one writes for the kind
        "version-newer": (
            "error",
            lambda m, d: _set(m, "format_version", np.array(_version(m) + 1)),
        ),
        "version-str": ("any", lambda m, d: _set(m, "format_version", np.array("1"))),
        "version-float-nan": ("error", lambda m, d: _set(m, "format_version", np.array(np.nan))),
        "version-missing": (
            "error",
            lambda m, d: {k: v for k, v in m.items() if k != "format_version"},
        ),
        "no-t": ("error", lambda m, d: {k: v for k, v in m.items() if k != "t"}),
        "no-main": ("error", lambda m, d: {k: v for k, v in m.items() if k != MAIN_ARRAY[kind]}),
        "t-int": ("any", t_as(lambda t: np.round(t * 1000).astype(np.int64))),
        "t-str": ("error", lambda m, d: _set(m, "t", np.asarray(m["t"]).astype(str))),
        "t-complex": ("error", lambda m, d: _set(m, "t", np.asarray(m["t"]).astype(complex))),
        "t-float16": ("any", lambda m, d: _set(m, "t", np.asarray(m["t"]).astype(np.float16))),
        "t-bigendian": ("any", lambda m, d: _set(m, "t", np.asarray(m["t"]).astype(">f8"))),
        "t-bool": ("error", lambda m, d: _set(m, "t", np.ones(_n(m), bool))),
        "t-2d": ("error", lambda m, d: _set(m, "t", np.asarray(m["t"])[:, None])),
        "t-scalar": ("error", lambda m, d: _set(m, "t", np.array(1.0))),
        "t-pickle": (
            "error",
            lambda m, d: _set(m, "t", np.array([_Marker(str(d / MARKER))] * _n(m), dtype=object)),
        ),
        "t-reversed": ("error", t_as(lambda t: t[::-1].copy())),
        "t-constant": ("error", t_as(lambda t: np.zeros_like(t))),
        "t-duplicate-step": ("any", t_as(lambda t: np.concatenate([t[:5], t[4:-1]]))),
        "t-inf": ("error", t_as(lambda t: np.where(np.arange(t.size) == t.size - 1, np.inf, t))),
        "t-nan": ("error", nan_at("t", every=False)),
        "t-negative-start": ("any", t_as(lambda t: t - 100.0)),
        "t-huge-offset": ("any", t_as(lambda t: t + 1.7e9)),  # a Unix time stamp
        "t-ms": ("complain", t_as(lambda t: t * 1000.0)),
        "t-frames": ("complain", t_as(lambda t: np.arange(t.size, dtype=float))),
        "t-us": ("complain", t_as(lambda t: t * 1e6)),
        "pos-mm": ("complain", scaled(pos, 1000.0)),
        "pos-nan-one": ("any", nan_at(pos, every=False)),
        "pos-nan-all": ("error", nan_at(pos, every=True)),
        "pos-inf": (
            "error",
            lambda m, d: _set(m, pos, np.full_like(np.asarray(m[pos], float), np.inf)),
        ),
        "pos-1e308": (
            "error",
            lambda m, d: _set(m, pos, np.full_like(np.asarray(m[pos], float), 1e308)),
        ),
        "pos-wrong-width": ("error", lambda m, d: _set(m, pos, np.asarray(m[pos])[:, :2])),
        "pos-short": ("error", lambda m, d: _set(m, pos, np.asarray(m[pos])[:-1])),
        "pos-fortran": ("any", lambda m, d: _set(m, pos, np.asfortranarray(m[pos]))),
        "samples-0": ("error", lambda m, d: _cut(m, 0)),
        "samples-1": ("error", lambda m, d: _cut(m, 1)),
        "samples-2": ("any", lambda m, d: _cut(m, 2)),
        "header-1e12": ("error", lambda m, d: _set(m, "t", crafted_header((10**12,)))),
        "header-negative": ("error", lambda m, d: _set(m, "t", crafted_header((-5,)))),
        "header-garbage": ("error", lambda m, d: _set(m, "t", b"\x93NUMPY\x01\x00\x10\x00{'x'")),
        "header-pos-1e12": ("error", lambda m, d: _set(m, pos, crafted_header((10**12, 3)))),
        "header-object-dtype": ("error", lambda m, d: _set(m, pos, crafted_header((3,), "|O"))),
        "extra-small": ("any", lambda m, d: _set(m, "note_array", np.arange(10.0))),
        "extra-huge-header": ("any", lambda m, d: _set(m, "junk", crafted_header((10**12,)))),
        "member-traversal": ("any", lambda m, d: _set(m, "../../evil", np.arange(3.0))),
    }
    if kind == "demonstration":
        muts["valid-all-false"] = ("error", lambda m, d: _set(m, "valid", np.zeros(_n(m), bool)))
        muts["quat-zero"] = (
            "error",
            lambda m, d: _set(m, "quaternion", np.zeros_like(np.asarray(m["quaternion"], float))),
        )
        muts["gripper-mm"] = ("complain", scaled("gripper", 1000.0))
        muts["keypoints-wrong"] = (
            "error",
            lambda m, d: _set(m, "keypoints", np.zeros((_n(m), 5, 3))),
        )
    if kind == "model":
        muts["cov-negative"] = ("error", lambda m, d: _set(m, "cov", -np.asarray(m["cov"])))
        muts["gmm-weights-nan"] = ("error", nan_at("gmm_weights", every=True))
    if kind == "plan":
        muts["quat-zero"] = (
            "error",
            lambda m, d: _set(m, "quaternion", np.zeros_like(np.asarray(m["quaternion"], float))),
        )
        muts["velocity-huge"] = ("complain", scaled("velocity", 1e6))
        muts["t-over-600s"] = (  # a plan lasts at most 600 s: simulate records every 1 ms
            "error",
            t_as(lambda t: t[0] + (t - t[0]) * 600.5 / (t[-1] - t[0])),
        )
    if kind in ("demonstration", "plan", "rollout"):  # the grasp array is on the time axis
        muts["grasp-wrong-len"] = ("error", lambda m, d: _set(m, "grasp", np.ones(3, bool)))
        muts["grasp-one-short"] = (
            "error",
            lambda m, d: _set(m, "grasp", np.asarray(m["grasp"])[:-1]),
        )
    if kind == "rollout":
        muts["q-wrong-width"] = ("error", lambda m, d: _set(m, "q", np.asarray(m["q"])[:, :6]))
    return muts


def byte_mutators() -> dict[str, tuple[str, Callable[[bytes], bytes]]]:
    rng = np.random.default_rng(7)

    def flip(b: bytes) -> bytes:
        a = bytearray(b)
        for i in rng.integers(len(a) // 4, len(a), 16):
            a[int(i)] ^= 0xFF
        return bytes(a)

    return {
        "empty": ("error", lambda b: b""),
        "random": ("error", lambda b: rng.bytes(4096)),
        "text": ("error", lambda b: b"t,x,y,z\n0,1,2,3\n"),
        "trunc-10": ("error", lambda b: b[: len(b) // 10]),
        "trunc-50": ("error", lambda b: b[: len(b) // 2]),
        "trunc-99": ("error", lambda b: b[: len(b) - 100]),
        "flipped": ("error", flip),
        "zip-empty": ("error", lambda b: _empty_zip()),
        "zip-text-member": ("error", lambda b: _zip_with({"meta.npy": b"hello"})),
    }


def _empty_zip() -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w"):
        pass
    return buf.getvalue()


def _zip_with(members: dict[str, bytes]) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as zf:
        for name, data in members.items():
            zf.writestr(name, data)
    return buf.getvalue()


def _version(m: dict[str, Any]) -> int:
    """The ``format_version`` a valid file's members hold."""
    return int(np.asarray(m["format_version"]))


def meta_type_mutators(kind: str, fixture: Path) -> dict[str, Mutator]:
    """Every top-level meta key of a valid file of ``kind`` set to values of the wrong type."""
    meta = _meta(read_members(fixture))
    wrong: dict[str, Any] = {"str": "x", "int": 1, "list": [1, "a"], "null": None,
                             "dict": {"a": {"b": []}}}  # fmt: skip
    out: dict[str, Mutator] = {}
    for key in sorted(meta):
        if key in ("kind", "software"):
            continue
        kinds = ["str", "list", "dict"] if not isinstance(meta[key], str) else ["int", "dict"]
        if isinstance(meta[key], dict | list):
            kinds.append("null")
        for w in kinds:

            def f(m: dict[str, Any], d: Path, key: str = key, w: str = w) -> dict[str, Any]:
                return _with_meta(m, {**_meta(m), key: wrong[w]})

            out[f"meta.{key}={w}"] = f
    return out


OBSTACLE_VARIANTS: dict[str, Any] = {
    "not-a-list": {"a": 1},
    "entry-int": [1],
    "entry-str": ["box"],
    "entry-empty": [{}],
    "center-str": "center:x",
    "center-short": "center:[1, 2]",
    "size-null": "size:null",
    "kind-unknown": "type:blob",
    "center-nan": "center:NaN",
}


def _obstacles(m: dict[str, Any], variant: Any) -> dict[str, Any]:
    """The plan's obstacle records (its fact ``obstacle_passes``) replaced by ``variant``."""
    facts = dict(json.loads(str(m["facts"])))
    if isinstance(variant, str):
        key, _, raw = variant.partition(":")
        entry = dict(facts["obstacle_passes"][0])
        if raw == "NaN":
            entry[key] = [float("nan")] * 3
        else:
            try:
                entry[key] = json.loads(raw)
            except ValueError:  # a bare word: the string itself
                entry[key] = raw
        facts["obstacle_passes"] = [entry]
    else:
        facts["obstacle_passes"] = variant
    return _set(m, "facts", np.array(json.dumps(facts)))


# --------------------------------------------------------------------------- case builders


def _put(*pairs: tuple[str, str]) -> Setup:
    """Copy fixtures into the case folder: (fixture key, name)."""

    def setup(d: Path, fx: Fixtures) -> None:
        for key, name in pairs:
            dest = d / name
            dest.parent.mkdir(parents=True, exist_ok=True)
            fx.copy(key, dest)

    return setup


def _chain(*setups: Setup | None) -> Setup:
    def setup(d: Path, fx: Fixtures) -> None:
        for s in setups:
            if s is not None:
                s(d, fx)

    return setup


def _mutated(key: str, name: str, mutate: Mutator) -> Setup:
    def setup(d: Path, fx: Fixtures) -> None:
        members = read_members(fx.path(key))
        result = mutate(members, d)
        if isinstance(result, bytes):
            (d / name).write_bytes(result)
        elif result is not None:
            write_members(d / name, result)

    return setup


def _bytes_of(key: str, name: str, change: Callable[[bytes], bytes]) -> Setup:
    def setup(d: Path, fx: Fixtures) -> None:
        (d / name).write_bytes(change(fx.path(key).read_bytes()))

    return setup


def _mkdir(name: str) -> Setup:
    return lambda d, fx: (d / name).mkdir()


def _write(name: str, data: bytes | str) -> Setup:
    def setup(d: Path, fx: Fixtures) -> None:
        p = d / name
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(data.encode() if isinstance(data, str) else data)

    return setup


DEMOS3 = _put(("demos", "demos"))
DEMO_ARGS = ["demos/demo_00.npz", "demos/demo_01.npz", "demos/demo_02.npz"]

# consumers of each file kind: (command argv with {f} for the file, outputs on success, needs)
CONSUMERS: dict[str, list[tuple[str, list[str], tuple[str, ...], Setup | None]]] = {
    "demonstration": [
        (
            "learn",
            ["learn", "demos/demo_00.npz", "demos/demo_01.npz", "{f}", "--k", "2", "-o", "m.npz"],
            ("m.npz",),
            DEMOS3,
        ),  # fmt: skip
        ("export-csv", ["export", "{f}", "-o", "out.csv"], ("out.csv",), None),
    ],
    "model": [("plan", ["plan", "{f}", "--rate-hz", "100", "-o", "p.npz"], ("p.npz",), None)],
    "plan": [
        ("simulate", ["simulate", "{f}", "--no-noise", "-o", "r.npz"], ("r.npz",), None),
        ("export-csv", ["export", "{f}", "-o", "out.csv"], ("out.csv",), None),
    ],
    "rollout": [
        ("export-csv", ["export", "{f}", "-o", "out.csv"], ("out.csv",), None),
        ("export-mcap", ["export", "{f}", "-o", "bag"], ("bag/**",), None),
    ],
}
FIXTURE_OF = {"demonstration": "demo", "model": "model", "plan": "plan", "rollout": "rollout"}


def file_cases(fx: Fixtures, quick_meta: bool) -> Iterator[Case]:
    """Crafted, truncated and mistyped files of every kind, fed to their consumers."""
    for kind, consumers in CONSUMERS.items():
        key = FIXTURE_OF[kind]
        name = "bad.npz"
        for cname, argv, outs, base in consumers:
            argv_f = [a.replace("{f}", name) for a in argv]
            for mname, (expect, change) in byte_mutators().items():
                yield Case(
                    f"{argv[0]}/file/{kind}/{cname}/{mname}", [argv_f], expect,
                    f"a {kind} file that is {mname}: refused naming it",
                    _chain(base, _bytes_of(key, name, change)), outs, needles=(name,),
                )  # fmt: skip
            for mname, (expect, mut) in structural_mutators(kind).items():
                yield Case(
                    f"{argv[0]}/file/{kind}/{cname}/{mname}", [argv_f], expect,
                    f"a {kind} file with {mname}",
                    _chain(base, _mutated(key, name, mut)), outs,
                    needles=(name,) if expect == "error" else (),
                )  # fmt: skip
        # meta of the wrong type: every key, on the first consumer only
        cname, argv, outs, base = consumers[0]
        argv_f = [a.replace("{f}", name) for a in argv]
        if not quick_meta:
            for mname, mut in meta_type_mutators(kind, fx.path(key)).items():
                yield Case(
                    f"{argv[0]}/meta/{kind}/{mname}", [argv_f], "any",
                    f"a {kind} whose {mname.split('=')[0]} has the wrong type: used or "
                    "refused in one line", _chain(base, _mutated(key, name, mut)), outs,
                )  # fmt: skip
    # a plan's obstacles of the wrong type, in simulate and in the study
    for vname, variant in OBSTACLE_VARIANTS.items():

        def mut(m: dict[str, Any], d: Path, v: Any = variant) -> dict[str, Any]:
            return _obstacles(m, v)

        setup = _mutated("plan_obstacle", "po.npz", mut)
        yield Case(f"simulate/obstacles/{vname}",
                   [["simulate", "po.npz", "--no-noise", "-o", "r.npz"]], "any",
                   "plan obstacle records of the wrong type", setup, ("r.npz",))  # fmt: skip
        yield Case(f"experiment/obstacles/{vname}",
                   [["experiment", "payload", "--plan", "po.npz", "--controllers", "pd",
                     "--workers", "1", "-o", "ex", "--json", "ex.json"]], "any",
                   "plan obstacle records of the wrong type", setup,
                   ("ex/**", "ex.json"))  # fmt: skip
    # a 2.5 GB array of zeros in a small file
    for cname, argv, outs, base in CONSUMERS["demonstration"]:
        argv_f = [a.replace("{f}", "bomb.npz") for a in argv]
        yield Case(f"{argv[0]}/file/demonstration/{cname}/zip-bomb", [argv_f], "any",
                   "2.5 GB of zeros compressed into a 2.5 MB extra array: never loaded",
                   _chain(base, _put(("bomb", "bomb.npz"))), outs)  # fmt: skip


def wrong_kind_cases() -> Iterator[Case]:
    files = {"demonstration": ("demo", "d.npz"), "model": ("model", "m.npz"),
             "plan": ("plan", "p.npz"), "rollout": ("rollout", "r.npz")}  # fmt: skip
    takes = {
        "learn": (["learn", "demos/demo_00.npz", "demos/demo_01.npz", "{f}", "-o", "out.npz"],
                  "demonstration", DEMOS3),
        "plan": (["plan", "{f}", "-o", "out.npz"], "model", None),
        "simulate": (["simulate", "{f}", "-o", "out.npz"], "plan", None),
        "experiment": (["experiment", "payload", "--plan", "{f}", "--workers", "1",
                        "--controllers", "pd", "-o", "ex"], "plan", None),
    }  # fmt: skip
    for cmd, (argv, wants, base) in takes.items():
        for kind, (key, name) in files.items():
            if kind == wants:
                continue
            yield Case(f"{cmd}/wrong-kind/{kind}", [[a.replace("{f}", name) for a in argv]],
                       "error", f"a {kind} given where a {wants} is read",
                       _chain(base, _put((key, name))), needles=(name,))  # fmt: skip
    yield Case("export/wrong-kind/model", [["export", "m.npz", "-o", "o.csv"]], "any",
               "export of a model: exported or refused in one line", _put(("model", "m.npz")),
               ("o.csv",))  # fmt: skip
    for name, kind in (("x.csv", "csv"), ("m.npz", "lerobot")):
        yield Case(f"learn/wrong-kind/{kind}-dir", [["learn", *DEMO_ARGS[:2], name, "-o", "o.npz"]],
                   "error", "a folder or a csv where a demonstration is read",
                   _chain(DEMOS3, _write(f"{name}/x", "1")), needles=(name,))  # fmt: skip


# numeric flags: (command, flag, base argv, int?, lo, lo_open, hi, hi_open, outputs, in-range
# expectation, setup)
@dataclass
class Flag:
    cmd: str
    flag: str
    base: list[str]
    integer: bool
    lo: float | None
    lo_open: bool
    hi: float | None
    hi_open: bool
    outputs: tuple[str, ...]
    inside: str  # expectation inside the range
    setup: Setup | None
    ends: bool = True  # run the stated ends too (they must work)


def _flags() -> list[Flag]:
    learn = ["learn", *DEMO_ARGS, "-o", "m.npz"]
    plan = ["plan", "m.npz", "--rate-hz", "100", "-o", "p.npz"]
    sim = ["simulate", "p.npz", "--no-noise", "-o", "r.npz"]
    exp = ["experiment", "payload", "--controllers", "pd", "--duration-s", "6", "--workers", "1",
           "-o", "ex", "--json", "ex.json"]  # fmt: skip
    rec = ["record", "v.mp4", "-o", "d.npz"]
    tel = ["teleop", "v.mp4", "-o", "t.npz"]
    cal = ["calibrate", "board.png", "--board", BOARD, "--board-pose", BOARD_POSE, "-o", "e.npy"]
    prn = ["calibrate", "--print-board", "b.png", "--board", BOARD]
    mk = _put(("model", "m.npz"))
    pl = _put(("plan", "p.npz"))
    vid = _put(("video", "v.mp4"))
    brd = _put(("board", "board.png"))
    seed = 2**32 - 1
    ex_out = ("ex/**", "ex.json")
    return [
        Flag(
            "synth",
            "-n",
            ["synth", "-o", "out"],
            True,
            1,
            False,
            1000,
            False,
            ("out/**",),
            "ok",
            None,
            ends=False,
        ),
        Flag(
            "synth",
            "--seed",
            ["synth", "-n", "1", "-o", "out"],
            True,
            0,
            False,
            seed,
            False,
            ("out/**",),
            "ok",
            None,
        ),
        Flag("learn", "--k", learn, True, 1, False, 50, False, ("m.npz",), "any", DEMOS3),
        Flag("learn", "--window", learn, True, 1, False, None, False, ("m.npz",), "any", DEMOS3),
        Flag(
            "learn",
            "--band-fraction",
            learn + ["--k", "3"],
            False,
            0,
            True,
            1,
            False,
            ("m.npz",),
            "ok",
            DEMOS3,
        ),
        Flag(
            "learn",
            "--max-gap-s",
            learn + ["--k", "3"],
            False,
            0,
            False,
            60,
            False,
            ("m.npz",),
            "ok",
            DEMOS3,
        ),
        Flag(
            "learn",
            "--n-query",
            learn + ["--k", "3"],
            True,
            2,
            False,
            100000,
            False,
            ("m.npz",),
            "ok",
            DEMOS3,
        ),
        Flag(
            "learn",
            "--seed",
            learn + ["--k", "3"],
            True,
            0,
            False,
            seed,
            False,
            ("m.npz",),
            "ok",
            DEMOS3,
        ),
        Flag(
            "learn",
            "--reference",
            learn + ["--k", "3"],
            True,
            0,
            False,
            2,
            False,
            ("m.npz",),
            "ok",
            DEMOS3,
        ),
        Flag(
            "plan",
            "--duration-s",
            plan,
            False,
            0,
            True,
            540,
            False,
            ("p.npz",),
            "ok",
            mk,
        ),
        # whether a margin can be cleared depends on the obstacle: at 1 m it cannot (one line)
        Flag("plan", "--margin-m", plan, False, 0, False, 1, False, ("p.npz",), "any", mk),
        Flag("plan", "--influence-m", plan, False, 0, True, 1, False, ("p.npz",), "ok", mk),
        Flag(
            "plan",
            "--rate-hz",
            ["plan", "m.npz", "--duration-s", "1", "-o", "p.npz"],
            False,
            0,
            True,
            10000,
            False,
            ("p.npz",),
            "ok",
            mk,
        ),
        Flag(
            "plan", "--place-surface-m", plan, False, 0, False, None, False, ("p.npz",), "any", mk
        ),
        Flag(
            "plan", "--object-bottom-m", plan, False, 0, False, None, False, ("p.npz",), "any", mk
        ),
        Flag("simulate", "--payload", sim, False, 0, False, 3, False, ("r.npz",), "any", pl),
        Flag("simulate", "--model-error", sim, False, 0, False, 0.99, False, ("r.npz",), "any", pl),
        Flag("simulate", "--seed", sim, True, 0, False, seed, False, ("r.npz",), "ok", pl),
        Flag("simulate", "--torque-delay", sim, True, 0, False, 100, False, ("r.npz",), "any", pl),
        Flag(
            "experiment",
            "--duration-s",
            exp[:4] + exp[6:],
            False,
            0,
            True,
            60,
            False,
            ex_out,
            "any",
            None,
            ends=False,
        ),
        Flag("experiment", "--model-error", exp, False, 0, False, 0.99, False, ex_out, "any", None),
        Flag(
            "experiment",
            "--workers",
            exp[:6] + exp[8:],
            True,
            1,
            False,
            64,
            False,
            ex_out,
            "any",
            None,
            ends=False,
        ),
        Flag(
            "experiment",
            "--trials",
            exp,
            True,
            0,
            False,
            None,
            False,
            ex_out,
            "any",
            None,
            ends=False,
        ),
        Flag("experiment", "--seed", exp, True, 0, False, seed, False, ex_out, "any", None),
        Flag(
            "experiment",
            "--sim-lockstep-s",
            exp,
            False,
            0,
            True,
            600,
            False,
            ex_out,
            "any",
            None,
            ends=False,
        ),
        Flag("record", "--max-frames", rec, True, 1, False, 1e7, False, ("d.npz",), "any", vid),
        Flag(
            "record",
            "--resize-width-px",
            rec,
            True,
            16,
            False,
            7680,
            False,
            ("d.npz",),
            "any",
            vid,
        ),
        Flag("record", "--fov-deg", rec, False, 1, False, 179, False, ("d.npz",), "any", vid),
        Flag(
            "record",
            "--assumed-depth-m",
            rec + ["--lift", "assumed_depth"],
            False,
            0,
            True,
            None,
            False,
            ("d.npz",),
            "any",
            vid,
        ),
        Flag(
            "record",
            "--camera-height-m",
            rec + ["--camera-pose", "front"],
            False,
            0.05,
            False,
            10,
            False,
            ("d.npz",),
            "any",
            vid,
        ),
        Flag("record", "--max-hands", rec, True, 1, False, 4, False, ("d.npz",), "any", vid),
        Flag(
            "record",
            "--grasp-threshold-m",
            rec + ["--grasp", "absolute"],
            False,
            0.005,
            False,
            0.2,
            False,
            ("d.npz",),
            "any",
            vid,
        ),
        Flag("record", "--max-gap-s", rec, False, 0, False, 5, False, ("d.npz",), "any", vid),
        Flag("record", "--workers", rec, True, 1, False, 64, False, ("d.npz",), "any", vid),
        Flag("teleop", "--max-frames", tel, True, 1, False, 1e7, False, ("t.npz",), "any", vid),
        Flag(
            "teleop",
            "--render-width-px",
            tel + ["--video", "t.mp4"],
            True,
            16,
            False,
            640,
            False,
            ("t.npz", "t.mp4"),
            "any",
            vid,
        ),
        Flag(
            "teleop",
            "--render-height-px",
            tel + ["--video", "t.mp4"],
            True,
            16,
            False,
            480,
            False,
            ("t.npz", "t.mp4"),
            "any",
            vid,
        ),
        Flag("teleop", "--payload", tel, False, 0, False, 3, False, ("t.npz",), "any", vid),
        Flag("teleop", "--model-error", tel, False, 0, False, 0.99, False, ("t.npz",), "any", vid),
        Flag("teleop", "--scale", tel, False, 0, True, 10, False, ("t.npz",), "any", vid),
        Flag("teleop", "--smoothing-s", tel, False, 0, False, 2, False, ("t.npz",), "any", vid),
        Flag("teleop", "--max-speed", tel, False, 0, True, 1.7, False, ("t.npz",), "any", vid),
        Flag(
            "teleop", "--max-angular-speed", tel, False, 0, True, 2.5, False, ("t.npz",), "any", vid
        ),
        Flag(
            "teleop", "--max-gripper-speed", tel, False, 0, True, 0.2, False, ("t.npz",), "any", vid
        ),
        Flag("teleop", "--reach-radius", tel, False, 0, True, 0.855, False, ("t.npz",), "any", vid),
        Flag("teleop", "--fov-deg", tel, False, 1, False, 179, False, ("t.npz",), "any", vid),
        Flag("calibrate", "--fov-deg", cal, False, 0, True, 180, True, ("e.npy",), "any", brd),
        Flag("calibrate", "--max-frames", cal, True, 1, False, None, False, ("e.npy",), "any", brd),
        Flag(
            "calibrate", "--min-corners", cal, True, 4, False, None, False, ("e.npy",), "any", brd
        ),
        Flag("calibrate", "--max-rms-px", cal, False, 0, True, 100, False, ("e.npy",), "any", brd),
        Flag(
            "calibrate",
            "--dpi",
            prn,
            False,
            0,
            True,
            4800,
            False,
            ("b.png",),
            "any",
            None,
            ends=False,
        ),
        Flag(
            "export",
            "--fps",
            ["export", "demos/demo_00.npz", "demos/demo_01.npz", "-o", "ds"],
            False,
            0,
            True,
            None,
            False,
            ("ds/**",),
            "any",
            DEMOS3,
        ),
        Flag(
            "demo",
            "--seed",
            ["demo", "-o", "out"],
            True,
            0,
            False,
            seed,
            False,
            ("out/**",),
            "any",
            None,
            ends=False,
        ),
        Flag(
            "demo",
            "--workers",
            ["demo", "-o", "out"],
            True,
            1,
            False,
            64,
            False,
            ("out/**",),
            "any",
            None,
            ends=False,
        ),
    ]


def _fmt_num(x: float, integer: bool) -> str:
    if integer and float(x).is_integer() and abs(x) < 1e18:
        return str(int(x))
    return repr(float(x))


def flag_cases() -> Iterator[Case]:
    """Absurd numbers for every numeric flag, and just past (and at) the ends of its range."""
    for f in _flags():
        values: list[tuple[str, str, str]] = [  # (label, value, expectation)
            ("nan", "nan", "error"), ("inf", "inf", "error"), ("-inf", "-inf", "error"),
            ("1e308", "1e308", "error"), ("-1", "-1", "error"), ("word", "abc", "error"),
            ("empty", "", "error"),
        ]  # fmt: skip
        if f.integer:
            values.append(("fraction", "1.5", "error"))
        if f.lo is not None:
            if f.lo != 0 and f.lo != -1:
                below = f.lo - 1 if f.integer else f.lo * (1 - 1e-6) - 1e-12
                values.append(("below-lo", _fmt_num(below, f.integer), "error"))
            elif f.lo == 0 and not f.integer:
                values.append(("below-lo", "-1e-9", "error"))
            lo_value = _fmt_num(f.lo, f.integer)
            if f.lo_open:
                values.append(("at-lo(open)", lo_value, "error"))
            elif f.ends and lo_value != "-1":
                values.append(("at-lo", lo_value, f.inside))
        if f.hi is not None:
            above = f.hi + 1 if f.integer else f.hi * (1 + 1e-6) + 1e-12
            values.append(("above-hi", _fmt_num(above, f.integer), "error"))
            hi_value = _fmt_num(f.hi, f.integer)
            if f.hi_open:
                values.append(("at-hi(open)", hi_value, "error"))
            elif f.ends:
                values.append(("at-hi", hi_value, f.inside))
        seen: set[str] = set()
        for label, value, expect in values:
            if value in seen:
                continue
            seen.add(value)
            if value == "0" and f.lo is not None and f.lo <= 0 and not f.lo_open:
                expect = f.inside
            yield Case(
                f"{f.cmd}/flag/{f.flag}={label}", [[*f.base, f.flag, value]], expect,
                f"{f.flag} {value!r}: range stated in --help is "
                f"{'(' if f.lo_open else '['}{f.lo}, {f.hi}{')' if f.hi_open else ']'}",
                f.setup, f.outputs,
                needles=(f.flag,) if expect == "error" else (),
            )  # fmt: skip


def unit_and_value_cases() -> Iterator[Case]:
    """Unit mistakes and malformed values of the non-scalar flags."""
    mk = _put(("model", "m.npz"))
    plan = ["plan", "m.npz", "--rate-hz", "100", "-o", "p.npz"]
    for flag, value, expect, why in [
        ("--start", "500,0,300", "complain", "a start in millimetres"),
        ("--goal", "500,0,300", "complain", "a goal in millimetres"),
        ("--goal", "0.5,0", "error", "two coordinates"),
        ("--goal", "0.5,0,0.2,0.1", "error", "four coordinates"),
        ("--goal", "nan,0,0.2", "error", "NaN"),
        ("--goal", "1e308,0,0.2", "error", "1e308"),
        ("--start", "a,b,c", "error", "words"),
        ("--start", "", "error", "empty"),
        ("--goal-quat", "0,0,0,0", "error", "zero quaternion"),
        ("--goal-quat", "0,0,0,2", "any", "a non-unit quaternion (normalised or refused)"),
        ("--goal-quat", "0,0,1", "error", "three numbers"),
        ("--goal-quat", "nan,0,0,1", "error", "NaN"),
        ("--obstacle", "box:450,0,200,100,100,100", "complain", "a box in millimetres"),
        ("--obstacle", "sphere:0.45,0,0.2,-0.1", "error", "negative radius"),
        ("--obstacle", "sphere:0.45,0,0.2,1e308", "error", "huge radius"),
        ("--obstacle", "sphere:0.45,0,0.2,nan", "error", "NaN radius"),
        ("--obstacle", "box:0.45,0,0.2", "error", "too few numbers"),
        ("--obstacle", "cone:0.45,0,0.2,0.1", "error", "unknown shape"),
        ("--obstacle", "box:0.45,0,0.2,0.1,0.1,0.1@+q", "error", "unknown side"),
        ("--obstacle", "sphere:0.45,0,0.2,0.05@auto", "any", "auto side"),
        ("--obstacle", "box:0.45,0,0.2,0,0,0", "error", "zero-size box"),
        ("--obstacle", "sphere:" + ",".join(["0.1"] * 10000), "error", "10000 numbers"),
        ("--duration-s", "5000", "error", "a duration in milliseconds"),
    ]:
        yield Case(f"plan/value/{flag}={value[:40]}", [[*plan, flag, value]], expect, why, mk,
                   ("p.npz",), needles=(flag,) if expect == "error" else ())  # fmt: skip
    many = [a for i in range(300) for a in ("--obstacle", f"sphere:0.{i % 9 + 1},0,0.2,0.01")]
    yield Case("plan/value/300-obstacles", [[*plan, *many]], "any", "300 obstacles: bounded",
               mk, ("p.npz",))  # fmt: skip
    exp = ["experiment", "payload", "--controllers", "pd", "--duration-s", "6", "--workers", "1",
           "-o", "ex", "--json", "ex.json"]  # fmt: skip
    for flag, value, expect in [
        ("--mc-payload-kg", "1.5,0.2", "error"), ("--mc-payload-kg", "0,300", "error"),
        ("--mc-payload-kg", "nan,1", "error"), ("--mc-payload-kg", "0.5", "any"),
        ("--mc-model-error", "0,1.5", "error"), ("--mc-model-error", "-1,0", "error"),
        ("--mc-noise-scale", "0,1e308", "error"), ("--mc-noise-scale", "-1,1", "error"),
        ("--mc-delay-ticks", "100000000,100000001", "error"),
        ("--mc-delay-ticks", "0,1.5", "error"),
        ("--mc-delay-ticks", "-2,0", "error"), ("--controllers", "pd,nope", "error"),
        ("--controllers", "", "error"), ("--controllers", ",".join(["pd"] * 200), "any"),
        ("--trials", "1000000000", "error"), ("--trials", "1", "any"),
    ]:  # fmt: skip
        argv = [*exp, flag, value]
        if flag.startswith("--mc") and flag != "--trials":
            argv += ["--trials", "1"]
        yield Case(f"experiment/value/{flag}={value[:30]}", [argv], expect,
                   f"{flag} {value[:30]}", None, ("ex/**", "ex.json"),
                   needles=(flag,) if expect == "error" else ())  # fmt: skip
    learn = ["learn", *DEMO_ARGS, "-o", "m.npz"]
    for flag, value, expect in [
        ("--reference", "medoid", "ok"),
        ("--reference", "3", "error"),
        ("--reference", "-1", "error"),
        ("--reference", "best", "error"),
    ]:
        yield Case(f"learn/value/{flag}={value}", [[*learn, flag, value, "--k", "3"]], expect,
                   f"{flag} {value}", DEMOS3, ("m.npz",),
                   needles=(flag,) if expect == "error" else ())  # fmt: skip
    yield Case("learn/value/one-demo", [["learn", DEMO_ARGS[0], "-o", "m.npz"]], "any",
               "a single demonstration", DEMOS3, ("m.npz",))  # fmt: skip
    yield Case("learn/value/same-demo-thrice", [["learn", *[DEMO_ARGS[0]] * 3, "-o", "m.npz"]],
               "any", "the same file three times", DEMOS3, ("m.npz",))  # fmt: skip
    # units in demonstrations handed to learn: all three demos in the wrong unit
    for label, mut in [
        ("t-ms", lambda m, d: _set(m, "t", np.asarray(m["t"], float) * 1000)),
        ("t-frames", lambda m, d: _set(m, "t", np.arange(_n(m), dtype=float))),
        ("pos-mm", lambda m, d: _set(m, "position", np.asarray(m["position"], float) * 1000)),
        ("8-samples-ms", lambda m, d: _set(_cut(m, 8), "t", np.arange(8) * 33.0)),
    ]:

        def in_units(d: Path, fx: Fixtures, mut: Mutator = mut) -> None:
            (d / "demos").mkdir()
            for i in range(3):
                members = read_members(fx.path("demos") / f"demo_0{i}.npz")
                result = mut(members, d)
                assert isinstance(result, dict)
                write_members(d / "demos" / f"demo_0{i}.npz", result)

        yield Case(f"learn/units/{label}", [[*learn]], "complain",
                   f"every demonstration with {label}", in_units, ("m.npz",))  # fmt: skip
    # camera files
    rec = ["record", "v.mp4", "-o", "d.npz"]
    vid = _put(("video", "v.mp4"))
    e_mm = np.eye(4)
    e_mm[:3, 3] = [600.0, 0.0, 1000.0]
    not_rigid = np.eye(4) * 2
    not_rigid[3, 3] = 1
    bad_last = np.eye(4)
    bad_last[3] = [1, 0, 0, 1]
    extr: list[tuple[str, Callable[[], bytes], str]] = [
        ("mm.npy", lambda: _npy_bytes(e_mm), "complain"),
        ("scaled.npy", lambda: _npy_bytes(not_rigid), "error"),
        ("lastrow.npy", lambda: _npy_bytes(bad_last), "error"),
        ("3x3.npy", lambda: _npy_bytes(np.eye(3)), "error"),
        ("nan.npy", lambda: _npy_bytes(np.full((4, 4), np.nan)), "error"),
        ("str.npy", lambda: _npy_bytes(np.array([["a"] * 4] * 4)), "error"),
        ("pickle.npy", lambda: _npy_bytes(np.array([_Marker(MARKER)], dtype=object)), "error"),
        ("huge.npy", lambda: crafted_header((10**6, 10**6)), "error"),
        ("empty.npy", lambda: b"", "error"),
        ("text.txt", lambda: b"1 0 0 600\n0 1 0 0\n0 0 1 1000\n0 0 0 1\n", "complain"),
        ("short.txt", lambda: b"1 0 0\n0 1 0\n", "error"),
        ("words.txt", lambda: b"one two three four\n" * 4, "error"),
    ]
    for name, make, expect in extr:
        for cmd in ("record", "teleop"):
            argv = (
                [*rec, "--extrinsics", name]
                if cmd == "record"
                else ["teleop", "v.mp4", "-o", "t.npz", "--extrinsics", name]
            )
            yield Case(f"{cmd}/extrinsics/{name}", [argv], expect,
                       f"--extrinsics {name}", _chain(vid, _write(name, make())),
                       ("d.npz", "t.npz"), needles=("--extrinsics", name)
                       if expect == "error" else ())  # fmt: skip
    intr: list[tuple[str, str | None, bytes, str]] = [
        ("inline-neg", "-500,500,48,32", b"", "error"),
        ("inline-zero", "0,0,0,0", b"", "error"),
        ("inline-nan", "nan,500,48,32", b"", "error"),
        ("inline-three", "500,500,48", b"", "error"),
        ("inline-huge", "1e308,1e308,48,32", b"", "error"),
        ("inline-mm", "0.5,0.5,0.048,0.032", b"", "complain"),
        (
            "k.json",
            None,
            json.dumps({"K": [[500, 0, 48], [0, 500, 32], [0, 0, 1]]}).encode(),
            "any",
        ),
        ("deep.json", None, _deep(100000).encode(), "error"),
        ("list.json", None, b"[1, 2, 3]", "error"),
        ("str.json", None, json.dumps({"K": "abc"}).encode(), "error"),
        ("nested.json", None, json.dumps({"K": [[[500]]]}).encode(), "error"),
        ("null.json", None, b"null", "error"),
        ("huge.json", None, ("[" + "1," * (5 << 20) + "1]").encode(), "error"),
        ("garbage.yaml", None, b"%YAML:1.0\n: : :\n\t- [", "error"),
        (
            "bomb.yaml",
            None,
            b"a: &a [x,x,x,x,x,x,x,x,x]\nb: &b [*a,*a,*a,*a,*a,*a,*a,*a]\n"
            b"c: &c [*b,*b,*b,*b,*b,*b,*b,*b]\nd: &d [*c,*c,*c,*c,*c,*c,*c,*c]\n"
            b"e: &e [*d,*d,*d,*d,*d,*d,*d,*d]\nf: &f [*e,*e,*e,*e,*e,*e,*e,*e]\n"
            b"g: [*f,*f,*f,*f,*f,*f,*f,*f]\n",
            "error",
        ),
        ("k.xml", None, b"<opencv_storage><K>1 2</K>", "error"),
        ("k.npy", None, _npy_bytes(np.eye(2)), "error"),
        ("missing.npy", None, b"", "error"),
    ]
    for name, inline, data, expect in intr:
        for cmd in ("record", "calibrate"):
            if cmd == "record":
                argv = [*rec, "--intrinsics", inline or name]
                setup = vid
                outs: tuple[str, ...] = ("d.npz",)
            else:
                argv = ["calibrate", "board.png", "--board", BOARD, "--board-pose", BOARD_POSE,
                        "-o", "e.npy", "--intrinsics", inline or name]  # fmt: skip
                setup = _put(("board", "board.png"))
                outs = ("e.npy",)
            if inline is None and name != "missing.npy":
                setup = _chain(setup, _write(name, data))
            yield Case(f"{cmd}/intrinsics/{name}", [argv], expect, f"--intrinsics {name}",
                       setup, outs,
                       needles=("--intrinsics", name) if expect == "error" else ())  # fmt: skip
    cal = ["calibrate", "board.png", "-o", "e.npy"]
    brd = _put(("board", "board.png"))
    for board, pose, expect, why in [
        ("charuco:5x7,40,30", BOARD_POSE, "complain", "board sizes in millimetres"),
        (BOARD, "500,0,0,0,0,0", "complain", "board pose in millimetres"),
        (BOARD, "0.5,0,0,0,0", "error", "five pose numbers"),
        (BOARD, "0.5,0,0,nan,0,0", "error", "NaN angle"),
        (BOARD, "0.5,0,0,0,0,1e308", "error", "huge angle"),
        (BOARD, "pose.npy", "error", "a 3x3 pose file"),
        ("charuco:0x0,0.04,0.03", BOARD_POSE, "error", "0x0 board"),
        ("charuco:100000x100000,0.04,0.03", BOARD_POSE, "error", "10^10 squares"),
        ("charuco:5x7,0.03,0.04", BOARD_POSE, "error", "marker larger than square"),
        ("charuco:5x7,-0.04,0.03", BOARD_POSE, "error", "negative square"),
        ("charuco:5x7,0.04,0.03,NOPE", BOARD_POSE, "error", "unknown dictionary"),
        ("charuco:5x7,nan,0.03", BOARD_POSE, "error", "NaN square"),
        ("charuco:5x7", BOARD_POSE, "error", "no sizes"),
        ("aprilgrid:6x6,0.03,0.009", BOARD_POSE, "any", "an aprilgrid that is not in the image"),
        ("checkerboard:9x6,0.025", BOARD_POSE, "any", "a checkerboard that is not in the image"),
        ("checkerboard:9x6,25", BOARD_POSE, "complain", "checkerboard squares in millimetres"),
        ("dots:5x7,0.04", BOARD_POSE, "error", "unknown board"),
        ("", BOARD_POSE, "error", "empty board"),
    ]:
        setup = (
            brd if pose != "pose.npy" else _chain(brd, _write("pose.npy", _npy_bytes(np.eye(3))))
        )
        yield Case(f"calibrate/board/{board[:30]}|{pose[:20]}",
                   [[*cal, "--board", board, "--board-pose", pose]], expect, why, setup,
                   ("e.npy",), needles=("--board",) if expect == "error" else ())  # fmt: skip
    for board, dpi, expect, why in [
        ("charuco:5x7,40,30", "300", "complain", "a printed board in millimetres (40 m squares)"),
        ("charuco:1000x1000,0.04,0.03", "300", "error", "a board of 40 m x 40 m"),
        ("checkerboard:9x6,0.025", "4800", "any", "at the stated dpi limit"),
        ("charuco:5x7,0.04,0.03", "1e-300", "error", "a dpi of 1e-300"),
    ]:
        yield Case(f"calibrate/print/{board[:30]}@{dpi}",
                   [["calibrate", "--print-board", "b.png", "--board", board, "--dpi", dpi]],
                   expect, why, None, ("b.png",),
                   needles=("--board", "--dpi") if expect == "error" else ())  # fmt: skip


def _png_header(width: int, height: int) -> bytes:
    import struct
    import zlib

    def chunk(kind: bytes, data: bytes) -> bytes:
        return (
            struct.pack(">I", len(data))
            + kind
            + data
            + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)
        )

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    idat = zlib.compress(b"\x00" * 1024)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", idat) + chunk(b"IEND", b"")


def _source_needles(src: str) -> tuple[str, ...]:
    """What an error about SOURCE may name: it, its scheme (webcam, realsense) or its name."""
    return (src, "SOURCE", src.split(":")[0].rstrip("s"), src.split("\n")[0])


def source_cases() -> Iterator[Case]:
    """Videos, images and devices that are not what they claim."""

    def fifo(name: str) -> Setup:
        return lambda d, fx: os.mkfifo(d / name)

    def trunc(key: str, name: str, frac: float) -> Setup:
        return _bytes_of(key, name, lambda b: b[: int(len(b) * frac)])

    def link_loop(name: str) -> Setup:
        def s(d: Path, fx: Fixtures) -> None:
            (d / name).symlink_to(d / (name + ".2"))
            (d / (name + ".2")).symlink_to(d / name)

        return s

    srcs: list[tuple[str, str, Setup | None, float]] = [
        ("empty.mp4", "empty.mp4", _write("empty.mp4", b""), 60),
        ("text.mp4", "text.mp4", _write("text.mp4", "not a video\n"), 60),
        ("trunc-50.mp4", "trunc.mp4", trunc("video", "trunc.mp4", 0.5), 60),
        ("trunc-5.mp4", "trunc.mp4", trunc("video", "trunc.mp4", 0.05), 60),
        ("png-as-mp4", "img.mp4", _put(("board", "img.mp4")), 60),
        ("folder", "folder.mp4", lambda d, fx: (d / "folder.mp4").mkdir(), 60),
        ("missing", "missing.mp4", None, 60),
        ("fifo", "pipe.mp4", fifo("pipe.mp4"), 20),
        ("dev-zero", "/dev/zero", None, 20),
        ("link-loop", "loop.mp4", link_loop("loop.mp4"), 60),
        ("webcam-99", "webcam:99", None, 30),
        ("webcam-neg", "webcam:-1", None, 30),
        ("webcam-word", "webcam:abc", None, 30),
        ("webcams-pair", "webcams:98,99", None, 30),
        ("webcams-same", "webcams:98,98", None, 30),
        ("realsense", "realsense:000000", None, 30),
        ("bag-garbage", "x.bag", _write("x.bag", b"#ROSBAG V2.0\n" + bytes(4096)), 60),
        ("db3-garbage", "x.db3", _write("x.db3", b"SQLite format 3\x00" + bytes(4096)), 60),
        ("huge-frame-header", "huge.png", _write("huge.png", _png_header(30000, 30000)), 60),
        ("name-with-newline", "a\nb.mp4", _put(("video", "a\nb.mp4")), 60),
        ("name-dash", "-o.mp4", _put(("video", "-o.mp4")), 60),
    ]
    for label, src, setup, timeout in srcs:
        # a newline is legal in a file name: that video is used, or refused in one line
        expect = "any" if label == "name-with-newline" else "error"
        yield Case(f"record/source/{label}", [["record", src, "-o", "d.npz"]], expect,
                   f"a source that is {label}", setup, ("d.npz",), timeout=timeout,
                   needles=_source_needles(src))  # fmt: skip
        yield Case(f"teleop/source/{label}", [["teleop", src, "-o", "t.npz"]], expect,
                   f"a source that is {label}", setup, ("t.npz",), timeout=timeout,
                   needles=_source_needles(src))  # fmt: skip
    imgs: list[tuple[str, str, Setup | None, float]] = [
        ("empty.png", "empty.png", _write("empty.png", b""), 60),
        ("text.png", "text.png", _write("text.png", "not an image"), 60),
        ("trunc.png", "trunc.png", trunc("board", "trunc.png", 0.3), 60),
        ("huge-header.png", "huge.png", _write("huge.png", _png_header(30000, 30000)), 60),
        ("huge-1x.png", "wide.png", _write("wide.png", _png_header(2**31 - 1, 1)), 60),
        ("noise-video", "v.mp4", _put(("video", "v.mp4")), 60),
        ("folder", "f.png", lambda d, fx: (d / "f.png").mkdir(), 60),
        ("missing", "missing.png", None, 60),
        ("fifo", "pipe.png", fifo("pipe.png"), 20),
        ("dev-zero", "/dev/zero", None, 20),
    ]
    for label, src, setup, timeout in imgs:
        yield Case(f"calibrate/source/{label}",
                   [["calibrate", src, "--board", BOARD, "--board-pose", BOARD_POSE,
                     "-o", "e.npy"]], "error", f"an image that is {label}", setup,
                   timeout=timeout, needles=(src, "IMAGE"))  # fmt: skip
    for label, src, setup, timeout in srcs[:10]:
        yield Case(f"learn/source/{label}", [["learn", *DEMO_ARGS[:2], src, "-o", "m.npz"]],
                   "error", f"a demonstration that is {label}", _chain(DEMOS3, setup),
                   timeout=timeout, needles=(src,))  # fmt: skip
        yield Case(f"simulate/source/{label}", [["simulate", src, "-o", "r.npz"]], "error",
                   f"a plan that is {label}", setup, timeout=timeout,
                   needles=(src,))  # fmt: skip
        yield Case(f"export/source/{label}", [["export", src, "-o", "o.csv"]], "error",
                   f"an input that is {label}", setup, timeout=timeout,
                   needles=(src,))  # fmt: skip
        yield Case(f"plan/source/{label}", [["plan", src, "-o", "p.npz"]], "error",
                   f"a model that is {label}", setup, timeout=timeout,
                   needles=(src,))  # fmt: skip


# output hazards: (command, argv with {o} for the output and {i} for an input, the input
# name, the output's suffix, setup, extra outputs on success)
OUTPUTTERS: list[tuple[str, list[str], str, str, Setup, tuple[str, ...]]] = [
    ("learn", ["learn", *DEMO_ARGS, "--k", "3", "-o", "{o}"], DEMO_ARGS[2], ".npz", DEMOS3, ()),
    (
        "plan",
        ["plan", "m.npz", "--rate-hz", "100", "-o", "{o}"],
        "m.npz",
        ".npz",
        _put(("model", "m.npz")),
        (),
    ),
    (
        "simulate",
        ["simulate", "p.npz", "--no-noise", "-o", "{o}"],
        "p.npz",
        ".npz",
        _put(("plan", "p.npz")),
        (),
    ),
    ("export-csv", ["export", "p.npz", "-o", "{o}"], "p.npz", ".csv", _put(("plan", "p.npz")), ()),
    (
        "export-mcap",
        ["export", "r.npz", "--format", "mcap", "-o", "{o}"],
        "r.npz",
        "",
        _put(("rollout", "r.npz")),
        (),
    ),
    (
        "export-lerobot",
        ["export", *DEMO_ARGS[:2], "--format", "lerobot", "-o", "{o}"],
        DEMO_ARGS[0],
        "",
        DEMOS3,
        (),
    ),
    (
        "calibrate",
        ["calibrate", "board.png", "--board", BOARD, "--board-pose", BOARD_POSE, "-o", "{o}"],
        "board.png",
        ".npy",
        _put(("board", "board.png")),
        (),
    ),
    (
        "calibrate-print",
        ["calibrate", "--print-board", "{o}", "--board", BOARD, "--dpi", "60"],
        "",
        ".png",
        lambda d, fx: None,
        (),
    ),
    ("teleop", ["teleop", "v.mp4", "-o", "{o}"], "v.mp4", ".npz", _put(("video", "v.mp4")), ()),
    (
        "teleop-video",
        [
            "teleop",
            "v.mp4",
            "--video",
            "{o}",
            "--render-width-px",
            "64",
            "--render-height-px",
            "48",
        ],
        "v.mp4",
        ".mp4",
        _put(("video", "v.mp4")),
        (),
    ),
    (
        "experiment-json",
        [
            "experiment",
            "payload",
            "--controllers",
            "pd",
            "--duration-s",
            "1",
            "--workers",
            "1",
            "--plan",
            "p.npz",
            "-o",
            "ex",
            "--json",
            "{o}",
        ],
        "p.npz",
        ".json",
        _put(("plan", "p.npz")),
        ("ex/**",),
    ),
    (
        "simulate-plot",
        ["simulate", "p.npz", "--no-noise", "-o", "r.npz", "--plot", "{o}"],
        "p.npz",
        ".png",
        _put(("plan", "p.npz")),
        ("r.npz",),
    ),
    ("synth", ["synth", "-n", "2", "-o", "{o}"], "", "", lambda d, fx: None, ()),
]


def output_cases() -> Iterator[Case]:
    """Outputs onto inputs, through links, into odd folders, onto a full or read-only disk."""
    for name, argv, inp, suffix, setup, extra in OUTPUTTERS:
        cmd = argv[0]
        folder_out = suffix == ""
        good = f"out{suffix}"
        outs = (f"{good}/**",) if folder_out else (good,)

        def run(o: str, argv: list[str] = argv) -> list[list[str]]:
            return [[a.replace("{o}", o) for a in argv]]

        def link(kind: str, target: str, alias: str) -> Setup:
            def s(d: Path, fx: Fixtures) -> None:
                if kind == "sym":
                    (d / alias).symlink_to(d / target)
                else:
                    os.link(d / target, d / alias)

            return s

        if inp:
            yield Case(f"{cmd}/output/{name}/is-input", run(inp), "error",
                       "the output is the input", setup, needles=("-o", "--", inp))  # fmt: skip
            for kind in ("sym", "hard"):
                alias = f"alias{suffix}"
                yield Case(f"{cmd}/output/{name}/{kind}link-to-input", run(alias), "error",
                           f"the output is a {kind} link to the input",
                           _chain(setup, link(kind, inp, alias)), needles=(alias,))  # fmt: skip

        # an unrelated existing file at the output: replaced atomically (single file) or
        # refused (a folder output)
        def existing(d: Path, fx: Fixtures, good: str = good) -> None:
            (d / good).write_bytes(b"an earlier, unrelated file\n")

        if folder_out:
            yield Case(f"{cmd}/output/{name}/existing-file-at-folder", run(good), "error",
                       "a file where the output folder would go", _chain(setup, existing),
                       needles=(good,))  # fmt: skip

            def unrelated(d: Path, fx: Fixtures) -> None:
                (d / "out").mkdir()
                (d / "out" / "notes.txt").write_text("mine\n")
                (d / "out" / "demo_00.npz").write_bytes(b"my own file, not a demo\n")

            yield Case(f"{cmd}/output/{name}/folder-with-unrelated-files", run("out"), "error",
                       "an output folder holding a user's files", _chain(setup, unrelated),
                       needles=("out",))  # fmt: skip
        else:
            yield Case(f"{cmd}/output/{name}/existing-unrelated", run(good), "any",
                       "an existing file at the output: replaced whole on success only",
                       _chain(setup, existing), (*outs, *extra), may_change=(good,))  # fmt: skip
            yield Case(f"{cmd}/output/{name}/is-folder", run("outdir" + suffix), "error",
                       "the output names a folder",
                       _chain(setup, _mkdir(f"outdir{suffix}")),
                       needles=("outdir",))  # fmt: skip
            yield Case(f"{cmd}/output/{name}/wrong-suffix", run("out.txt"), "error",
                       "the output's suffix is not the format written", setup,
                       needles=("out.txt",))  # fmt: skip
        yield Case(f"{cmd}/output/{name}/missing-folder", run(f"no/such/{good}"), "any",
                   "an output in a folder that does not exist: created or refused",
                   setup, ("no/**",) + extra, needles=("no/such",))  # fmt: skip
        n255 = "x" * (255 - len(suffix)) + suffix
        if name.startswith(("export-mcap", "export-db3")):  # the bag's file is NAME.mcap
            yield Case(f"{cmd}/output/{name}/name-255-bytes", run(n255), "error",
                       "a bag folder leaves room for its file's name", setup,
                       needles=("at most",))  # fmt: skip
        else:
            yield Case(f"{cmd}/output/{name}/name-255-bytes", run(n255), "ok",
                       "a 255-byte file name is legal", setup,
                       (f"{n255}/**",) if folder_out else (n255, *extra))  # fmt: skip
        n256 = "x" * (256 - len(suffix)) + suffix
        yield Case(f"{cmd}/output/{name}/name-256-bytes", run(n256), "error",
                   "a 256-byte file name is not", setup, needles=("xxxx",))  # fmt: skip
        yield Case(f"{cmd}/output/{name}/read-only-folder", run(f"ro/{good}"), "error",
                   "a folder the user may not write (run as nobody)",
                   _chain(setup, lambda d, fx: (d / "ro").mkdir(mode=0o755)), nobody=True,
                   needles=("ro/",))  # fmt: skip
        if not folder_out:
            yield Case(f"{cmd}/output/{name}/dev-full", run("/dev/full"), "error",
                       "a device as the output (run as nobody)", setup, nobody=True,
                       needles=("/dev/full",))  # fmt: skip

            def sym_full(d: Path, fx: Fixtures, good: str = good) -> None:
                (d / good).symlink_to("/dev/full")

            yield Case(f"{cmd}/output/{name}/symlink-to-dev-full", run(good), "any",
                       "the output is a symlink to /dev/full (run as nobody)",
                       _chain(setup, sym_full), (*outs, *extra), may_change=(good,),
                       nobody=True)  # fmt: skip
        for limit in (0, 64 << 10):
            yield Case(f"{cmd}/output/{name}/disk-full-{limit >> 10}k", run(good),
                       "error" if limit == 0 else "any",
                       f"the disk fills after {limit >> 10} kB (RLIMIT_FSIZE): an output that "
                       "fits is written, else one line and no half-written file", setup,
                       (*outs, *extra), fsize=limit, needles=(good, "out", "File too large",
                       "No space"))  # fmt: skip

    # a user's file in a record output folder (two sources, -o out/)
    def two_videos(d: Path, fx: Fixtures) -> None:  # real hand videos: both would record
        fx.copy("real_video", d / "a.mp4")
        fx.copy("real_video", d / "b.mp4")
        (d / "out").mkdir()
        fx.copy("model", d / "out" / "a.npz")

    yield Case("record/output/folder-holds-a-model",
               [["record", "a.mp4", "b.mp4", "-o", "out/", "--max-frames", "60"]], "error",
               "out/a.npz is a user's model: never replaced", two_videos,
               needles=("a.npz", "out"))  # fmt: skip
    yield Case("record/output/overlay-folder-holds-a-file",
               [["record", "a.mp4", "b.mp4", "-o", "out/", "--overlay", "ov/", "--max-frames",
                 "60"]], "error",
               "never replaced", _chain(two_videos, _write("ov/a.mp4", b"mine")),
               needles=("a.mp4", "ov", "out"))  # fmt: skip
    yield Case("plan/output/plot-is-a-file",
               [["plan", "m.npz", "-o", "p.npz", "--plot", "fig"]], "error",
               "--plot names an existing file", _chain(_put(("model", "m.npz")),
                                                         _write("fig", b"mine")),
               needles=("--plot",))  # fmt: skip
    yield Case("learn/output/plot-holds-files",
               [["learn", *DEMO_ARGS, "--k", "3", "-o", "m.npz", "--plot", "fig"]], "any",
               "--plot folder holding a user's files", _chain(DEMOS3, _write("fig/notes.txt",
                                                                             b"mine")),
               ("m.npz", "fig/*.png"))  # fmt: skip
    yield Case("demo/output/folder-with-unrelated-files",
               [["demo", "-o", "out", "--no-real-video"]], "any",
               "a demo folder holding a user's files: refused, or run without touching them",
               _write("out/thesis.docx", b"my thesis"), ("out/**",), timeout=240,
               needles=("out",))  # fmt: skip


def chain_cases() -> Iterator[Case]:
    """Ordinary input: what one command writes, the next one reads."""
    mk = _put(("model", "m.npz"))
    for dur in ("0.5", "1.3", "5.1", "6.1", "7.1", "12.7"):
        for rate in ("100", "250", "333", "1000"):
            if dur == "12.7" and rate != "1000":
                continue
            yield Case(f"simulate/chain/plan-{dur}s-{rate}Hz",
                       [["plan", "m.npz", "--duration-s", dur, "--rate-hz", rate, "-o", "p.npz"],
                        ["simulate", "p.npz", "--no-noise", "-o", "r.npz"]],
                       "ok" if float(dur) >= 5 else "any",
                       "any plan that plan writes simulates (a safety stop on a plan too "
                       "fast for the arm is one line)", mk, ("p.npz", "r.npz"),
                       timeout=90)  # fmt: skip
    yield Case("simulate/chain/plan-540s", [
        ["plan", "m.npz", "--duration-s", "540", "--hold-s", "5", "--rate-hz", "100", "-o",
         "p.npz"],
        ["export", "p.npz", "-o", "p.csv"]], "ok",
        "the longest motion plan accepts is a plan every reader (simulate's gate) takes",
        mk, ("p.npz", "p.csv"), timeout=120)  # fmt: skip
    for dur in ("0.05", "1", "5.1", "60"):
        # a lift too fast for the Panda stops every run: one line, exit 1, and the table
        # and figure of where they stopped are kept
        fast = float(dur) < 2.0
        yield Case(f"experiment/chain/duration-{dur}",
                   [["experiment", "payload", "--controllers", "pd", "--duration-s", dur,
                     "--workers", "1", "-o", "ex", "--json", "ex.json"]], "any" if fast else "ok",
                   "every --duration-s experiment allows runs, or says every run stopped", None,
                   ("ex/**", "ex.json"), error_outputs=("ex/**", "ex.json") if fast else (),
                   timeout=120)  # fmt: skip
    yield Case("experiment/chain/plan-with-obstacle",
               [["experiment", "payload", "--controllers", "pd", "--plan", "po.npz",
                 "--workers", "1", "-o", "ex", "--json", "ex.json"]], "ok",
               "a plan with an obstacle drives the study", _put(("plan_obstacle", "po.npz")),
               ("ex/**", "ex.json"))  # fmt: skip
    pl = _put(("plan", "p.npz"))
    ro = _put(("rollout", "r.npz"))
    for name, setup, argv, outs in [
        ("plan-csv", pl, ["export", "p.npz", "-o", "p.csv"], ("p.csv",)),
        ("plan-mcap", pl, ["export", "p.npz", "-o", "bag"], ("bag/**",)),
        ("plan-db3", pl, ["export", "p.npz", "--format", "db3", "-o", "bag"], ("bag/**",)),
        ("rollout-csv", ro, ["export", "r.npz", "-o", "r.csv"], ("r.csv",)),
        ("demo-mcap", DEMOS3, ["export", DEMO_ARGS[0], "-o", "bag"], ("bag/**",)),
        ("lerobot", DEMOS3, ["export", *DEMO_ARGS, "-o", "ds"], ("ds/**",)),
        ("lerobot-rollout", ro, ["export", "r.npz", "--format", "lerobot", "-o", "ds"], ("ds/**",)),
        ("model-csv", mk, ["export", "m.npz", "-o", "m.csv"], ("m.csv",)),
    ]:
        yield Case(f"export/chain/{name}", [argv], "ok", "an ordinary export", setup, outs)
    yield Case("simulate/chain/video-without-MUJOCO_GL",
               [["simulate", "p.npz", "--no-noise", "-o", "r.npz", "--video", "r.mp4"]], "any",
               "without MUJOCO_GL: a video or one line", pl, ("r.npz", "r.mp4"),
               env={"MUJOCO_GL": "", "DISPLAY": ""})  # fmt: skip
    yield Case("simulate/chain/plot-and-rerun",
               [["simulate", "p.npz", "--no-noise", "-o", "r.npz", "--plot", "r.png"]], "ok",
               "an ordinary run with a figure", pl, ("r.npz", "r.png"))  # fmt: skip
    yield Case("calibrate/chain/board", [["calibrate", "board.png", "--board", BOARD,
                                          "--board-pose", BOARD_POSE, "-o", "e.npy"]],
               "ok", "the printed board, seen square-on", _put(("board", "board.png")),
               ("e.npy",))  # fmt: skip
    yield Case("synth/chain/learn-plan", [
        ["synth", "-n", "4", "-o", "demos"],
        ["learn", "demos/demo_00.npz", "demos/demo_01.npz", "demos/demo_02.npz",
         "demos/demo_03.npz", "-o", "m.npz", "--plot", "fig"],
        ["plan", "m.npz", "--rate-hz", "100", "-o", "p.npz", "--plot", "pfig"]], "ok",
        "synth -> learn -> plan with figures", None,
        ("demos/**", "m.npz", "fig/**", "p.npz", "pfig/**"), timeout=120)  # fmt: skip
    real = _put(("real_video", "hand.mp4"))
    yield Case("record/chain/real-video-lerobot", [
        ["record", "hand.mp4", "--max-frames", "60", "-o", "d.npz"],
        ["export", "d.npz", "--format", "lerobot", "-o", "ds"]], "ok",
        "a real recording exported with its video", real, ("d.npz", "ds/**"),
        timeout=120)  # fmt: skip
    e_mm = np.eye(4)
    e_mm[:3, 3] = [600.0, 0.0, 1000.0]
    yield Case("record/units/real-video-extrinsics-mm",
               [["record", "hand.mp4", "--max-frames", "60", "--extrinsics", "e.npy",
                 "-o", "d.npz"]], "complain",
               "extrinsics with the translation in millimetres",
               _chain(real, _write("e.npy", _npy_bytes(e_mm))), ("d.npz",),
               timeout=120)  # fmt: skip


def long_demos(n_min: int, count: int = 2) -> Setup:
    """``demos/demo_0I.npz``: the fixture's demonstrations, repeated to >= ``n_min`` samples."""

    def setup(d: Path, fx: Fixtures) -> None:
        (d / "demos").mkdir()
        for i in range(count):
            m = read_members(fx.path("demos") / f"demo_0{i}.npz")
            n = _n(m)
            reps = n_min // n + 1
            out = {}
            for k, v in m.items():
                if isinstance(v, np.ndarray) and v.ndim and v.shape[0] == n:
                    out[k] = np.concatenate([v] * reps)
                else:
                    out[k] = v
            dt = float(np.median(np.diff(m["t"])))
            out["t"] = np.arange(out["position"].shape[0]) * dt
            write_members(d / "demos" / f"demo_0{i}.npz", out)

    return setup


def misc_cases() -> Iterator[Case]:
    """Argument parsing: abbreviations, unknown and repeated flags, nothing at all."""
    mk = _put(("model", "m.npz"))
    for cid, argv, expect, setup, outs in [
        (
            "plan/args/abbrev-place",
            ["plan", "m.npz", "-o", "p.npz", "--place", "0.1"],
            "error",
            mk,
            (),
        ),
        (
            "experiment/args/absurd-workload",  # 100000 trials x 2 x 5 controllers x 60 s
            ["experiment", "payload", "--duration-s", "60", "--trials", "100000", "-o", "ex"],
            "error",
            None,
            ("ex/**",),
        ),
        (
            "export/output/bag-named-txt",  # was written as an MCAP bag folder named out.txt
            ["export", "r.npz", "-o", "out.txt"],
            "error",
            _put(("rollout", "r.npz")),
            (),
        ),
        (
            "export/output/bag-named-mcap",
            ["export", "r.npz", "--format", "mcap", "-o", "out.mcap"],
            "error",
            _put(("rollout", "r.npz")),
            (),
        ),
        (
            "export/output/bag-dated-name",
            ["export", "r.npz", "--format", "db3", "-o", "bag_2024.05"],
            "ok",
            _put(("rollout", "r.npz")),
            ("bag_2024.05/**",),
        ),
        (
            "export/lerobot/demonstration-and-rollout",  # one kind per dataset, said by name
            ["export", "demos/demo_00.npz", "r.npz", "--format", "lerobot", "-o", "ds"],
            "error",
            _chain(DEMOS3, _put(("rollout", "r.npz"))),
            (),
        ),
        (
            "learn/long/dtw-grid-over-bound",  # 2 x 32000 samples: 1.02e9 cells > 1e9
            ["learn", "demos/demo_00.npz", "demos/demo_01.npz", "-o", "m.npz"],
            "error",
            long_demos(32000),
            (),
        ),
        (
            "learn/long/dtw-grid-banded",  # the same with a band: 32000 x 6401 cells
            [
                "learn",
                "demos/demo_00.npz",
                "demos/demo_01.npz",
                "--k",
                "3",
                "--band-fraction",
                "0.1",
                "-o",
                "m.npz",
            ],
            "ok",
            long_demos(32000),
            ("m.npz",),
        ),
        (
            "learn/args/abbrev-band",
            ["learn", *DEMO_ARGS, "-o", "m.npz", "--band", "0.5"],
            "error",
            DEMOS3,
            (),
        ),
        (
            "simulate/args/abbrev-torque",
            ["simulate", "p.npz", "-o", "r.npz", "--torque", "2"],
            "error",
            _put(("plan", "p.npz")),
            (),
        ),
        (
            "plan/args/unknown-flag",
            ["plan", "m.npz", "-o", "p.npz", "--speed", "2"],
            "error",
            mk,
            (),
        ),
        ("plan/args/no-output", ["plan", "m.npz"], "error", mk, ()),
        (
            "plan/args/repeated-o",
            ["plan", "m.npz", "-o", "a.npz", "-o", "b.npz"],
            "any",
            mk,
            ("a.npz", "b.npz"),
        ),
        ("dexlfd/args/none", [], "error", None, ()),
        ("dexlfd/args/unknown-command", ["fly"], "error", None, ()),
        ("learn/args/no-demos", ["learn", "-o", "m.npz"], "error", None, ()),
        (
            "export/args/bad-format",
            ["export", "p.npz", "--format", "xlsx", "-o", "x"],
            "error",
            _put(("plan", "p.npz")),
            (),
        ),
        (
            "simulate/args/robot-unknown",
            ["simulate", "p.npz", "-o", "r.npz", "--robot", "abb"],
            "error",
            _put(("plan", "p.npz")),
            (),
        ),
        (
            "simulate/args/robot-franka-closed",
            ["simulate", "p.npz", "-o", "r.npz", "--robot", "franka://127.0.0.1"],
            "error",
            _put(("plan", "p.npz")),
            (),
        ),
        ("experiment/args/unknown-study", ["experiment", "speed"], "error", None, ()),
        (
            "record/args/rerun-two-sources",
            ["record", "a.mp4", "b.mp4", "-o", "out/", "--rerun", "x.rrd"],
            "error",
            _chain(_put(("video", "a.mp4")), _put(("video", "b.mp4"))),
            (),
        ),
        (
            "teleop/args/video-wrong-suffix",
            ["teleop", "v.mp4", "--video", "t.avi"],
            "error",
            _put(("video", "v.mp4")),
            (),
        ),
        ("calibrate/args/nothing", ["calibrate", "--board", BOARD], "error", None, ()),
        (
            "calibrate/args/print-and-image",
            ["calibrate", "board.png", "--print-board", "b.png", "--board", BOARD],
            "error",
            _put(("board", "board.png")),
            (),
        ),
    ]:
        yield Case(cid, [argv], expect, "argument handling", setup, outs,
                   timeout=30)  # fmt: skip
    # closed port on 127.0.0.1 only: a cluster that cannot be reached fails within 15 s
    for addr in ("127.0.0.1:1", "ray://127.0.0.1:1"):
        yield Case(f"experiment/ray/{addr}",
                   [["experiment", "payload", "--controllers", "pd", "--duration-s", "6",
                     "--engine", "ray", "--ray-address", addr, "-o", "ex"]], "error",
                   "a cluster that cannot be reached: one line within 15 s", None,
                   timeout=20, needles=("--ray-address", addr))  # fmt: skip
        yield Case(f"record/ray/{addr}",
                   [["record", "a.mp4", "b.mp4", "-o", "out/", "--engine", "ray",
                     "--ray-address", addr]], "error",
                   "a cluster that cannot be reached: one line within 15 s",
                   _chain(_put(("video", "a.mp4")), _put(("video", "b.mp4"))), timeout=20,
                   needles=("--ray-address", addr))  # fmt: skip
    yield Case("experiment/ray/address-garbage",
               [["experiment", "payload", "--engine", "ray", "--ray-address", "::::", "-o",
                 "ex"]], "error", "a malformed address", None, timeout=20,
               needles=("--ray-address", "::::"))  # fmt: skip


def sigint_cases() -> Iterator[Case]:
    """Ctrl-C (SIGINT to the process group) while a command works; then look for leftovers."""
    mk = _put(("model", "m.npz"))

    big_demos = long_demos(20000)
    sim_long = ["plan", "m.npz", "--duration-s", "120", "--rate-hz", "100", "-o", "p.npz"]
    for label, steps, setup, delay, outs, err_outs in [
        (
            "learn-dtw",
            [["learn", "demos/demo_00.npz", "demos/demo_01.npz", "--k", "3", "-o", "m.npz"]],
            big_demos,
            8.0,
            ("m.npz",),
            (),
        ),
        (
            "simulate",
            [sim_long, ["simulate", "p.npz", "--no-noise", "-o", "r.npz"]],
            mk,
            8.0,
            ("p.npz", "r.npz"),
            ("p.npz", "r.npz", "r.partial.npz"),
        ),
        (
            "simulate-video",
            [sim_long, ["simulate", "p.npz", "--no-noise", "-o", "r.npz", "--video", "r.mp4"]],
            mk,
            10.0,
            ("p.npz", "r.npz", "r.mp4"),
            ("p.npz", "r.npz", "r.partial.npz"),
        ),
        (
            "plan-long",
            [["plan", "m.npz", "--duration-s", "540", "--rate-hz", "6000", "-o", "p.npz"]],
            mk,
            6.0,
            ("p.npz",),
            (),
        ),
        (
            "experiment",
            [["experiment", "payload", "--workers", "2", "-o", "ex", "--json", "ex.json"]],
            None,
            8.0,
            ("ex/**", "ex.json"),
            ("ex/**",),
        ),
        (
            "experiment-mc",
            [
                [
                    "experiment",
                    "payload",
                    "--trials",
                    "50",
                    "--controllers",
                    "pd",
                    "--workers",
                    "2",
                    "-o",
                    "ex",
                ]
            ],
            None,
            8.0,
            ("ex/**",),
            ("ex/**",),
        ),
        ("synth-1000", [["synth", "-n", "1000", "-o", "out"]], None, 5.0, ("out/**",), ("out/**",)),
        (
            "teleop-video",
            [["teleop", "v.mp4", "-o", "t.npz", "--video", "t.mp4"]],
            _put(("video", "v.mp4")),
            5.0,
            ("t.npz", "t.mp4"),
            ("t.npz", "t.partial.npz", "t.mp4"),  # the rollout and the video so far are kept
        ),
        (
            "record-real",
            [["record", "hand.mp4", "-o", "d.npz", "--overlay", "o.mp4"]],
            _put(("real_video", "hand.mp4")),
            8.0,
            ("d.npz", "o.mp4"),
            (),
        ),
        ("export-lerobot", [["export", *DEMO_ARGS, "-o", "ds"]], DEMOS3, 3.0, ("ds/**",), ()),
        ("demo", [["demo", "-o", "out", "--no-real-video"]], None, 25.0, ("out/**",), ("out/**",)),
    ]:
        yield Case(f"{steps[-1][0]}/ctrl-c/{label}", steps, "any",
                   "Ctrl-C: exit 130 within 5 s, finished outputs kept, no half-written file",
                   setup, outs, error_outputs=err_outs, sigint_after=delay, fresh=True,
                   timeout=delay + 5.0)  # fmt: skip
    # an interrupted demo, resumed: the strays of the first run are gone afterwards
    yield Case("demo/ctrl-c/resume", [["demo", "-o", "out", "--no-real-video"],
                                      ["demo", "-o", "out", "--no-real-video"]], "ok",
               "resume after Ctrl-C finishes and removes the strays", None, ("out/**",),
               sigint_after=25.0, fresh=True, timeout=240, sigint_step=0)  # fmt: skip


def _zip_patched(
    member: str, flags: int = 0, method: int | None = None
) -> Callable[[bytes], bytes]:
    """A change of an ``.npz``'s bytes: ``member``'s header flags OR-ed, its method set."""
    import struct

    def change(data: bytes) -> bytes:
        b = bytearray(data)
        info = zipfile.ZipFile(io.BytesIO(data)).getinfo(member)
        spots = [(info.header_offset, 6, 8)]
        at = data.find(b"PK\x01\x02")
        while at != -1:
            n = struct.unpack_from("<H", data, at + 28)[0]
            if data[at + 46 : at + 46 + n].decode() == member:
                spots.append((at, 8, 10))
            at = data.find(b"PK\x01\x02", at + 4)
        for off, flag_at, method_at in spots:
            old = struct.unpack_from("<H", b, off + flag_at)[0]
            struct.pack_into("<H", b, off + flag_at, old | flags)
            if method is not None:
                struct.pack_into("<H", b, off + method_at, method)
        return bytes(b)

    return change


def _zip_damaged(member: str, lzma: bool) -> Callable[[bytes], bytes]:
    """``member``'s compressed stream with bytes flipped (re-packed with LZMA first)."""
    import struct

    def change(data: bytes) -> bytes:
        if lzma:
            zin, out = zipfile.ZipFile(io.BytesIO(data)), io.BytesIO()
            with zipfile.ZipFile(out, "w") as zo:
                for i in zin.infolist():
                    kind = zipfile.ZIP_LZMA if i.filename == member else zipfile.ZIP_DEFLATED
                    zo.writestr(i.filename, zin.read(i.filename), compress_type=kind)
            data = out.getvalue()
        b = bytearray(data)
        info = zipfile.ZipFile(io.BytesIO(data)).getinfo(member)
        n, x = struct.unpack_from("<HH", b, info.header_offset + 26)
        start = info.header_offset + 30 + n + x
        for i in range(start + 2, start + min(40, info.compress_size)):
            b[i] ^= 0x5A
        return bytes(b)

    return change


def _lerobot(change: str) -> Setup:
    """A LeRobot dataset ``ds`` of three synthetic demonstrations, then ``change`` made."""

    def setup(d: Path, fx: Fixtures) -> None:
        import pyarrow as pa
        import pyarrow.parquet as pq

        from dexlfd.datasets import pick_place_demonstrations
        from dexlfd.io.lerobot import export_lerobot

        demos = pick_place_demonstrations(3, np.random.default_rng(5))
        root = export_lerobot(demos, d / "ds")
        info_path = root / "meta" / "info.json"
        data = sorted((root / "data").glob("chunk-*/file-*.parquet"))
        eps = sorted((root / "meta" / "episodes").glob("chunk-*/file-*.parquet"))
        if change in ("features-list", "features-nested"):
            info = json.loads(info_path.read_text())
            info["features"] = [] if change == "features-list" else "@"
            text = json.dumps(info)
            if change == "features-nested":
                text = text.replace('"@"', "[" * 100_000 + "]" * 100_000)
            info_path.write_text(text)
            return
        files = eps if change == "meta-not-json" else data
        for f in files:
            t = pq.read_table(f)
            if change in ("no-episode_index", "no-timestamp"):
                t = t.drop_columns([change[3:]])
            elif change == "meta-not-json":
                i = t.column_names.index("dexlfd/meta")
                t = t.set_column(i, "dexlfd/meta", pa.array(["{not json"] * t.num_rows))
            elif change == "state-strings":
                i = t.column_names.index("observation.state")
                rows = [[str(v) for v in r] for r in t.column(i).to_pylist()]
                t = t.set_column(i, "observation.state", pa.array(rows))
            pq.write_table(t, f)

    return setup


def reliability3_cases() -> Iterator[Case]:
    """Damaged zip members, malformed LeRobot datasets, outputs onto other flags' inputs,
    folders of a user's files, SIGTERM and SIGHUP."""
    damages = ("encrypted", "zstd-93", "aes-99", "lzma-damaged", "deflate-garbage")
    for kind, consumers in CONSUMERS.items():
        for member in ("meta.npy", "t.npy"):
            for label in damages:
                if label == "lzma-damaged":
                    change = _zip_damaged(member, lzma=True)
                elif label == "deflate-garbage":
                    change = _zip_damaged(member, lzma=False)
                else:
                    flags, method = {"encrypted": (1, None), "zstd-93": (0, 93),
                                     "aes-99": (0, 99)}[label]  # fmt: skip
                    change = _zip_patched(member, flags, method)
                for _name, argv, _outs, needs in consumers[:1]:
                    yield Case(
                        f"{argv[0]}/zip/{kind}/{member}/{label}",
                        [[a.replace("{f}", "bad.npz") for a in argv]], "error",
                        f"a {kind} whose {member} is {label}",
                        _chain(needs, _bytes_of(FIXTURE_OF[kind], "bad.npz", change)),
                        needles=("bad.npz",),
                    )  # fmt: skip
    for change in ("no-episode_index", "no-timestamp", "features-list", "features-nested",
                   "meta-not-json", "state-strings"):  # fmt: skip
        yield Case(f"learn/lerobot/{change}", [["learn", "ds", "--k", "2", "-o", "m.npz"]],
                   "error", f"a LeRobot dataset: {change}", _lerobot(change),
                   needles=("ds",), timeout=120)  # fmt: skip
    # an output onto a file another flag names
    calib = ["calibrate", "img.png", "--board", "checkerboard:9x6,0.025"]
    pose = _write("pose.npy", _npy_bytes(np.eye(4)))
    k = _write("K.npy", _npy_bytes(np.array([500.0, 500.0, 320.0, 240.0])))
    img = _write("img.png", b"\x89PNG not really")
    two = _chain(_write("top.mp4", b"not really"), _write("side.mp4", b"not really"))
    for label, argv, setup, needle in [
        ("board-pose", [*calib, "--board-pose", "pose.npy", "-o", "pose.npy"],
         _chain(pose, img), "pose.npy"),
        ("intrinsics", [*calib, "--board-pose", "pose.npy", "--intrinsics", "K.npy", "-o",
                        "K.npy"], _chain(pose, k, img), "K.npy"),
        ("record-two-cameras", ["record", "videos:top.mp4,side.mp4", "-o", "r.npz",
                                "--overlay", "top.mp4"], two, "top.mp4"),
        ("teleop-two-cameras", ["teleop", "videos:top.mp4,side.mp4", "--video", "side.mp4"],
         two, "side.mp4"),
    ]:  # fmt: skip
        yield Case(f"{argv[0]}/output/other-flag/{label}", [argv], "error",
                   "an output onto a file another flag names", setup,
                   needles=(needle,))  # fmt: skip
    for label, argv, setup, needle in [
        ("experiment-payload", ["experiment", "payload", "-o", "ex", "--workers", "1"],
         _write("ex/payload_lift_z.png", b"my figure"), "payload_lift_z.png"),
        ("experiment-generalize", ["experiment", "generalize", "m.npz", "-o", "gen"],
         _chain(_put(("model", "m.npz")), _write("gen/generalize.txt", "my notes")),
         "generalize.txt"),
        ("demo", ["demo", "-o", "out", "--no-real-video"],
         _write("out/model.npz", b"my model"), "model.npz"),
    ]:  # fmt: skip
        yield Case(f"{argv[0]}/output/users-file-in-folder/{label}", [argv], "error",
                   "a user's file where the command writes one of its own", setup,
                   needles=(needle,))  # fmt: skip
    yield Case("experiment/payload-ignores-model", [["experiment", "payload", "m.npz", "-o",
               "ex"]], "error", "experiment payload given a MODEL it would ignore",
               _put(("model", "m.npz")), needles=("MODEL",))  # fmt: skip
    # SIGTERM / SIGHUP to the run's process: as Ctrl-C, with 143 / 129
    mk = _put(("model", "m.npz"))
    sim_long = ["plan", "m.npz", "--duration-s", "120", "--rate-hz", "100", "-o", "p.npz"]
    for sig, name in ((signal.SIGTERM, "sigterm"), (signal.SIGHUP, "sighup")):
        for label, steps, setup, delay, outs, err_outs in [
            ("learn-plot", [["learn", "demos/demo_00.npz", "demos/demo_01.npz", "--k", "3",
                             "-o", "m.npz", "--plot", "figs"]],
             long_demos(20000), 8.0, ("m.npz", "figs/**"), ("figs/**",)),
            ("simulate-video", [sim_long, ["simulate", "p.npz", "--no-noise", "-o", "r.npz",
                                           "--video", "r.mp4"]], mk, 10.0,
             ("p.npz", "r.npz", "r.mp4"), ("p.npz", "r.npz", "r.partial.npz")),
            ("experiment", [["experiment", "payload", "--workers", "2", "-o", "ex"]], None,
             8.0, ("ex/**",), ("ex/**",)),
            ("demo", [["demo", "-o", "out", "--no-real-video"]], None, 25.0, ("out/**",),
             ("out/**",)),
            ("record-overlay", [["record", "hand.mp4", "-o", "d.npz", "--overlay", "o.mp4"]],
             _put(("real_video", "hand.mp4")), 8.0, ("d.npz", "o.mp4"), ()),
            ("teleop-video", [["teleop", "v.mp4", "-o", "t.npz", "--video", "t.mp4"]],
             _put(("video", "v.mp4")), 5.0, ("t.npz", "t.mp4"),
             ("t.npz", "t.partial.npz", "t.mp4")),
        ]:  # fmt: skip
            yield Case(f"{steps[-1][0]}/{name}/{label}", steps, "any",
                       f"{name.upper()}: exit {128 + sig} within 5 s, outputs kept, no "
                       "half-written file", setup, outs, error_outputs=err_outs,
                       sigint_after=delay, fresh=True, timeout=delay + 5.0,
                       stop_signal=sig)  # fmt: skip


_STRAY = ".{}.k3v9x0qa.dexlfd-part{}"  # a temporary's name (io._atomic), mkstemp's 8 chars


def _strays(*names: str) -> Setup:
    """Temporaries a killed run left: ``dir/name`` (a file) or ``dir/name/`` (a folder)."""

    def setup(d: Path, fx: Fixtures) -> None:
        for name in names:
            folder = name.endswith("/")
            target = Path(name.rstrip("/"))
            suffix = target.suffix if target.suffix in (".mp4", ".png") else ""
            stray = d / target.parent / _STRAY.format(target.name, suffix)
            stray.parent.mkdir(parents=True, exist_ok=True)
            if folder:
                (stray / target.name).mkdir(parents=True)
                (stray / target.name / "half.txt").write_text("half")
            else:
                stray.write_bytes(b"half-written")

    return setup


def _stray_patterns(*names: str) -> tuple[str, ...]:
    out = []
    for name in names:
        target = Path(name.rstrip("/"))
        suffix = target.suffix if target.suffix in (".mp4", ".png") else ""
        rel = (target.parent / _STRAY.format(target.name, suffix)).as_posix()
        out.append(rel + "/**" if name.endswith("/") else rel)
    return tuple(out)


def _giant_frame_landmarks(d: Path, fx: Fixtures) -> None:
    src = fx.data / "landmarks" / "llama.npz"
    if not src.exists():
        raise FileNotFoundError(src)
    with np.load(src, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    arrays["frame_size_px"] = np.array([10**9, 10**9], dtype=np.int64)
    np.savez(d / "lm.npz", **arrays)


def recheck_cases() -> Iterator[Case]:
    """The rest of the reliability list: strays of a killed run, bounds known up front,
    output names that are not UTF-8, a landmark file in the wrong unit."""
    mk, pk = _put(("model", "m.npz")), _put(("plan", "p.npz"))
    learn = ["learn", *DEMO_ARGS, "--k", "3"]
    sim = ["simulate", "p.npz", "--no-noise", "-o", "r.npz"]
    for label, argv, base, outs, names in [
        ("learn", [*learn, "-o", "m.npz", "--plot", "figs"], DEMOS3, ("m.npz", "figs/**"),
         ("m.npz", "figs/alignment.png")),
        ("simulate-video", [*sim, "--video", "r.mp4"], pk, ("r.npz", "r.mp4"),
         ("r.npz", "r.mp4")),
        ("export-lerobot", ["export", *DEMO_ARGS, "-o", "ds"], DEMOS3, ("ds/**",), ("ds/",)),
        ("teleop-video", ["teleop", "v.mp4", "-o", "t.npz", "--video", "t.mp4"],
         _put(("video", "v.mp4")), ("t.npz", "t.mp4"), ("t.npz", "t.mp4")),
        ("experiment", ["experiment", "payload", "--controllers", "pd", "--workers", "1",
                        "-o", "ex"], None, ("ex/**",), ("ex/payload_lift_z.png",)),
    ]:  # fmt: skip
        yield Case(f"{argv[0]}/strays/{label}", [argv], "ok",
                   "a killed run's temporaries are removed by the next successful run",
                   _chain(base, _strays(*names)), outs, gone=_stray_patterns(*names),
                   timeout=120)  # fmt: skip
    many = ",".join(f"{0.01 * i:g}" for i in range(200))
    twenty = ",".join(f"{0.1 * i:g}" for i in range(20))
    for label, extra, needle in [("pairs-10000-x-20-payloads",
                                  ["--pairs", "10000", "--payloads", twenty], "--pa"),
                                 ("payloads-200", ["--payloads", many], "--payloads")]:  # fmt: skip
        yield Case(f"experiment/bound/{label}",
                   [["experiment", "generalize", "m.npz", *extra, "-o", "gen"]], "error",
                   "a study too large: refused up front with its size", mk,
                   needles=(needle,))  # fmt: skip
    # the largest grid is within the bound: its size and duration said up front, then it
    # runs (with progress) until stopped
    yield Case("experiment/bound/pairs-10000", [["experiment", "generalize", "m.npz",
               "--pairs", "10000", "-o", "gen"]], "any",
               "the largest grid: estimated up front, stopped by SIGTERM like any run", mk,
               ("gen/**",), error_outputs=("gen/**",), sigint_after=20.0, fresh=True,
               timeout=25.0, stop_signal=signal.SIGTERM)  # fmt: skip
    odd = os.fsdecode(b"\xff")
    for label, argv, setup, outs, expect in [
        ("learn", [*learn, "-o", f"m{odd}.npz", "--plot", f"f{odd}"], DEMOS3,
         (f"m{odd}.npz", f"f{odd}/**"), "ok"),
        ("plan", ["plan", "m.npz", "--rate-hz", "100", "-o", f"p{odd}.npz"], mk, (f"p{odd}.npz",),
         "ok"),
        ("simulate", [*sim[:-1], f"r{odd}.npz", "--video", f"v{odd}.mp4"], pk,
         (f"r{odd}.npz", f"v{odd}.mp4"), "ok"),
        ("export-lerobot", ["export", *DEMO_ARGS, "-o", f"ds{odd}"], DEMOS3,
         (f"ds{odd}/**",), "ok"),
        ("export-mcap", ["export", "p.npz", "--format", "mcap", "-o", f"b{odd}"], pk,
         (f"b{odd}/**",), "any"),
        ("synth", ["synth", "-n", "2", "-o", f"s{odd}"], None, (f"s{odd}/**",), "ok"),
        ("experiment-json", ["experiment", "payload", "--controllers", "pd", "--workers", "1",
                             "-o", f"e{odd}", "--json", f"e{odd}.json"], None,
         (f"e{odd}/**", f"e{odd}.json"), "ok"),
    ]:  # fmt: skip
        yield Case(f"{argv[0]}/undecodable-name/{label}", [argv], expect,
                   "an output name with bytes that are not UTF-8 (legal on Linux)", setup,
                   outs, timeout=120)  # fmt: skip
    yield Case("record/landmarks/giant-frame", [["record", "lm.npz", "-o", "d.npz"]], "error",
               "a landmark recording whose frame is 1e9 px a side", _giant_frame_landmarks,
               needles=("frame_size_px",))  # fmt: skip


def all_cases(fx: Fixtures) -> list[Case]:
    cases = [
        *flag_cases(), *unit_and_value_cases(), *file_cases(fx, quick_meta=False),
        *wrong_kind_cases(), *source_cases(), *output_cases(), *chain_cases(), *misc_cases(),
        *sigint_cases(), *reliability3_cases(), *recheck_cases(),
    ]  # fmt: skip
    ids = [c.cid for c in cases]
    dup = {i for i in ids if ids.count(i) > 1}
    if dup:
        raise RuntimeError(f"duplicate case ids: {sorted(dup)[:5]}")
    return cases


# --------------------------------------------------------------------------- running


def _snapshot(root: Path) -> dict[str, str]:
    """rel path -> content digest (files), link target (symlinks), 'dir' (folders)."""
    out: dict[str, str] = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for name in dirnames + filenames:
            p = Path(dirpath) / name
            rel = p.relative_to(root).as_posix()
            try:
                st = os.lstat(p)
                if stat.S_ISLNK(st.st_mode):
                    out[rel] = "link:" + os.readlink(p)
                elif stat.S_ISDIR(st.st_mode):
                    out[rel] = "dir"
                elif stat.S_ISREG(st.st_mode):
                    h = hashlib.sha256()
                    with open(p, "rb") as fh:
                        for block in iter(lambda: fh.read(1 << 20), b""):
                            h.update(block)
                    out[rel] = h.hexdigest()
                else:
                    out[rel] = f"special:{st.st_mode:o}"
            except OSError as exc:
                out[rel] = f"error:{exc.errno}"
    return out


def _matches(rel: str, patterns: tuple[str, ...]) -> bool:
    for pat in patterns:
        if pat.endswith("/**"):
            base = pat[:-3]
            if rel == base or rel.startswith(base + "/"):
                return True
        elif fnmatch.fnmatchcase(rel, pat) or pat.startswith(rel + "/"):
            return True
    return False


def _hidden(rel: str, patterns: tuple[str, ...]) -> bool:
    """A hidden component that no pattern names explicitly (``dir/**`` does not)."""
    parts = rel.split("/")
    if parts[-1] == LEDGER and all(not p.startswith(".") for p in parts[:-1]):
        return False  # an output folder's record of what dexlfd wrote there: an output
    return any(p.startswith(".") for p in parts) and not any(
        fnmatch.fnmatchcase(rel, pat) and "/." in "/" + pat for pat in patterns
    )


_TRACE = ("Traceback (most recent call last)", "Exception ignored", "Fatal Python error",
          "FatalError", "Segmentation fault", "core dumped")  # fmt: skip
_MEMORY = ("MemoryError", "Unable to allocate", "bad_alloc", "Cannot allocate memory",
           "out of memory", "Insufficient memory")  # fmt: skip
_ERROR_LINE = re.compile(r"^dexlfd(?: [\w-]+)?: error: ")


def _first_line(stderr: str) -> str:
    for line in stderr.splitlines():
        if line.strip():
            return line.strip()[:300]
    return ""


def _error_line(stderr: str) -> str:
    lines = [ln for ln in stderr.splitlines() if _ERROR_LINE.match(ln)]
    return lines[-1][:400] if lines else ""


def _report_line(stderr: str) -> str:
    """The most telling line: the error line, else the last traceback line, else the first."""
    err = _error_line(stderr)
    if err:
        return err
    lines = [ln.strip() for ln in stderr.splitlines() if ln.strip()]
    raw = stderr.splitlines()
    starts = [i for i, ln in enumerate(raw) if ln.startswith("Traceback (most recent call")]
    if starts:
        after = [ln for ln in raw[starts[-1] + 1 :] if ln.strip() and not ln.startswith(" ")]
        if after:
            return after[0].strip()[:300]
    return lines[0][:300] if lines else ""


class Runner:
    """Runs cases (fork or fresh interpreter), at most ``jobs`` at a time."""

    def __init__(self, root: Path, fx: Fixtures, mem_bytes: int, jobs: int) -> None:
        self.root = root
        self.fx = fx
        self.mem = mem_bytes
        self.jobs = jobs
        self._procs: dict[int, subprocess.Popen[bytes]] = {}

    # -- one step
    def _child(self, case: Case, argv: list[str], cdir: Path, tmp: Path, err: int) -> None:
        """In the forked child: limits, redirections, then the command line."""
        code = 1
        try:
            os.setpgid(0, 0)
            signal.signal(signal.SIGINT, signal.default_int_handler)
            signal.signal(signal.SIGTERM, signal.SIG_DFL)
            resource.setrlimit(resource.RLIMIT_AS, (self.mem, self.mem))
            if case.fsize is not None:
                signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
                resource.setrlimit(resource.RLIMIT_FSIZE, (case.fsize, case.fsize))
            for k, v in {**self._env(tmp), **case.env}.items():
                if v:
                    os.environ[k] = v
                else:
                    os.environ.pop(k, None)
            tempfile.tempdir = None
            fd = err  # a pipe: not subject to RLIMIT_FSIZE
            null = os.open(os.devnull, os.O_RDWR)
            os.dup2(null, 0)
            os.dup2(null, 1)
            os.dup2(fd, 2)
            # the parent's sys.stderr may not be fd 2 (pytest's capture): use the fds
            sys.stdout = open(1, "w", buffering=1, closefd=False)  # noqa: SIM115
            # undecodable bytes escaped, as in CPython's own stderr
            sys.stderr = open(2, "w", 1, errors="backslashreplace", closefd=False)  # noqa: SIM115
            if case.nobody:
                os.setgroups([])
                os.setgid(NOBODY)
                os.setuid(NOBODY)
            os.chdir(cdir)
            from dexlfd.cli import main

            try:
                code = int(main(argv) or 0)
            except SystemExit as exc:
                if isinstance(exc.code, int) or exc.code is None:
                    code = int(exc.code or 0)
                else:
                    sys.stderr.write(f"{exc.code}\n")
                    code = 1
            except BaseException:  # what the interpreter would print and exit 1 with
                import traceback

                traceback.print_exc()
                code = 1
            gc.collect()  # "Exception ignored in ... __del__" appears here, as at exit
            atexit._run_exitfuncs()  # what the interpreter runs at exit (pool temp folders)
            sys.stderr.flush()
            sys.stdout.flush()
        except BaseException as exc:  # the harness itself failed in the child
            with contextlib.suppress(OSError):
                os.write(2, f"SWEEP HARNESS: {exc!r}\n".encode())
        finally:
            os._exit(code)

    def _env(self, tmp: Path) -> dict[str, str]:
        return {"TMPDIR": str(tmp), "MPLCONFIGDIR": str(tmp / ".mpl"),
                "HOME": str(tmp.parent / f"{tmp.name}.home"),
                "MPLBACKEND": "Agg", "PYTHONPATH": os.environ.get("PYTHONPATH", ""),
                "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}  # fmt: skip

    def _launch(self, case: Case, argv: list[str], cdir: Path, tmp: Path, err: int) -> int:
        if case.fresh:
            env = {**os.environ, **self._env(tmp)}
            for k, v in case.env.items():
                if v:
                    env[k] = v
                else:
                    env.pop(k, None)
            code = (  # SIGINT is ignored in a background job; a terminal's Ctrl-C is not
                "import resource, signal, sys; "  # (nor SIGHUP, ignored under nohup)
                "signal.signal(signal.SIGINT, signal.default_int_handler); "
                "signal.signal(signal.SIGHUP, signal.SIG_DFL); "
                f"resource.setrlimit(resource.RLIMIT_AS, ({self.mem}, {self.mem})); "
                "from dexlfd.cli import main; sys.exit(main(sys.argv[1:]))"
            )
            proc = subprocess.Popen(
                [sys.executable, "-c", code, *argv], cwd=cdir, env=env,
                stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=err,
                start_new_session=True,
            )  # fmt: skip
            self._procs[proc.pid] = proc  # kept: a collected Popen may reap the child itself
            return proc.pid
        sys.stdout.flush()
        sys.stderr.flush()
        gc.freeze()  # the child's collections skip the parent's heap (no copy-on-write storm)
        pid = os.fork()
        if pid == 0:  # pragma: no cover - the child
            self._child(case, argv, cdir, tmp, err)
        return pid

    # -- a case
    def prepare(self, case: Case, index: int) -> tuple[Path, Path, dict[str, str]]:
        cdir = self.root / "cases" / f"{index:04d}"
        tmp = self.root / "tmp" / f"{index:04d}"
        cdir.mkdir(parents=True)
        tmp.mkdir(parents=True)
        os.chmod(tmp, 0o777)
        (tmp / ".mpl").mkdir()
        os.chmod(tmp / ".mpl", 0o777)
        home = tmp.parent / f"{tmp.name}.home"  # a HOME of its own (caches, ~/.rum), unchecked
        home.mkdir()
        os.chmod(home, 0o777)
        if case.setup is not None:
            case.setup(cdir, self.fx)
        if case.nobody:
            for p in [cdir, *cdir.rglob("*")]:
                if p.is_dir() and not p.is_symlink() and p.name != "ro":
                    os.chmod(p, 0o777)
        return cdir, tmp, _snapshot(cdir)

    def run_all(self, cases: list[Case], progress: Callable[[int, Outcome], None]) -> list[Outcome]:
        pending = list(enumerate(cases))
        running: dict[int, dict[str, Any]] = {}  # pid -> state
        done: dict[int, Outcome] = {}
        while pending or running:
            while pending and len(running) < self.jobs:
                index, case = pending.pop(0)
                try:
                    cdir, tmp, before = self.prepare(case, index)
                except Exception as exc:  # a fixture that cannot be made here
                    outcome = Outcome(case, "skipped", f"setup failed: {exc!r}", [], [])
                    done[index] = outcome
                    progress(index, outcome)
                    continue
                state: dict[str, Any] = {"index": index, "case": case, "cdir": cdir, "tmp": tmp,
                         "before": before, "step": 0, "results": []}  # fmt: skip
                self._start_step(state)
                running[state["pid"]] = state
            time.sleep(0.05)
            now = time.monotonic()
            for pid, state in list(running.items()):
                case = state["case"]
                try:
                    wpid, status, usage = os.wait4(pid, os.WNOHANG)
                except ChildProcessError:
                    wpid, status, usage = pid, 0, None
                self._drain(state)
                if wpid == 0:
                    elapsed = now - state["t0"]
                    interrupt = case.sigint_after is not None and state["step"] == (
                        case.sigint_step % len(case.steps)
                    )
                    if interrupt and not state["sigint"] and elapsed >= case.sigint_after:
                        if case.stop_signal == signal.SIGINT:  # a terminal's Ctrl-C: the group
                            self._kill(pid, signal.SIGINT)
                        else:  # kill(1), systemd, Docker: the run's process alone
                            with contextlib.suppress(ProcessLookupError):
                                os.kill(pid, case.stop_signal)
                        state["sigint"] = now
                    if state["sigint"] and now - state["sigint"] > state["grace"]:
                        state["late"] = True
                        self._kill(pid, signal.SIGKILL)
                    elif elapsed > state["limit"]:
                        self._kill(pid, signal.SIGKILL)
                        state["killed"] = True
                    continue
                del running[pid]
                left = _left_running(pid)
                self._reap_group(pid)
                rc: int | None
                sig = None
                if os.WIFEXITED(status):
                    rc = os.WEXITSTATUS(status)
                else:
                    rc = None if state.get("killed") or state.get("late") else -1
                    sig = os.WTERMSIG(status) if os.WIFSIGNALED(status) else None
                self._drain(state, final=True)
                stderr = state["buf"].decode(errors="replace")
                state["results"].append(StepResult(
                    rc, sig, stderr, now - state["t0"],
                    (usage.ru_maxrss / 1024.0) if usage is not None else 0.0,
                    sigint_late=bool(state.get("late")), limit_s=state["limit"],
                    grace_s=state["grace"], left_running=left))  # fmt: skip
                last = state["results"][-1]
                more = state["step"] + 1 < len(case.steps)
                ok_so_far = last.rc == 0 or (last.rc == 130 and bool(state["sigint"]))
                if more and ok_so_far:
                    state["step"] += 1
                    self._start_step(state)
                    running[state["pid"]] = state
                    continue
                outcome = classify(
                    case,
                    state["results"],
                    state["cdir"],
                    state["tmp"],
                    state["before"],
                    all_steps=not more,
                )
                done[state["index"]] = outcome
                progress(state["index"], outcome)
                shutil.rmtree(state["cdir"], ignore_errors=True)
                shutil.rmtree(state["tmp"], ignore_errors=True)
                shutil.rmtree(f"{state['tmp']}.home", ignore_errors=True)
        return [done[i] for i in sorted(done)]

    def _start_step(self, state: dict[str, Any]) -> None:
        case = state["case"]
        read, write = os.pipe()
        state["pid"] = self._launch(case, case.steps[state["step"]], state["cdir"],
                                    state["tmp"], write)  # fmt: skip
        os.close(write)
        os.set_blocking(read, False)
        state["pipe"] = read
        state["buf"] = b""
        state["t0"] = time.monotonic()
        factor = load_factor()
        state["limit"] = case.timeout * factor
        if case.sigint_after is not None:  # the limit must not cut the grace short
            state["limit"] = max(state["limit"], case.sigint_after + SIGINT_GRACE_S * factor)
        state["grace"] = SIGINT_GRACE_S * factor
        state["sigint"] = 0.0
        state["killed"] = False
        state["late"] = False

    @staticmethod
    def _drain(state: dict[str, Any], final: bool = False) -> None:
        """Read what the child wrote to stderr so far (the first 4 MB are kept)."""
        fd = state["pipe"]
        while True:
            try:
                chunk = os.read(fd, 1 << 16)
            except BlockingIOError:
                break
            if not chunk:
                break
            if len(state["buf"]) < (4 << 20):
                state["buf"] += chunk
        if final:
            os.close(fd)

    @staticmethod
    def _kill(pid: int, sig: int) -> None:
        try:
            os.killpg(pid, sig)
        except (ProcessLookupError, PermissionError):
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, sig)

    @staticmethod
    def _reap_group(pid: int) -> None:
        """Kill what the case left running in its process group (pool workers, Ray)."""
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(pid, signal.SIGKILL)


def _members(pid: int) -> list[str]:
    """``PID NAME`` of the live (not zombie) processes of process group or session ``pid``."""
    found = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            stat = Path(f"/proc/{entry}/stat").read_text()
        except OSError:
            continue
        rest = stat[stat.rfind(")") + 2 :].split()  # state, ppid, pgrp, session, ...
        if rest[0] != "Z" and pid in (int(rest[2]), int(rest[3])):
            found.append(f"{entry} {stat[stat.find('(') + 1 : stat.rfind(')')]}")
    return found


def _left_running(pid: int, grace_s: float = 2.0) -> tuple[str, ...]:
    """What the ended step ``pid`` left running in its group or session, after a grace."""
    end = time.monotonic() + grace_s
    while True:
        left = _members(pid)
        if not left or time.monotonic() > end:
            return tuple(left)
        time.sleep(0.1)


def classify(case: Case, results: list[StepResult], cdir: Path, tmp: Path,
             before: dict[str, str], all_steps: bool) -> Outcome:  # fmt: skip
    """The class of one finished case (see the module docstring for the order)."""
    last = results[-1]
    stderr = "\n".join(r.stderr for r in results)
    after = _snapshot(cdir)
    found: list[tuple[str, str]] = []
    if (cdir / MARKER).exists() or Path(MARKER).exists():
        found.append(("pickle ran", "a pickled object in the input was unpickled"))
    success = last.rc == 0 and all_steps
    lost = [rel for rel, digest in before.items()
            if after.get(rel) != digest and not _matches(rel, (*case.may_change, *case.gone))
            and not (digest == "dir" and rel in after)]  # fmt: skip
    if success and case.may_change:
        lost = [r for r in lost if not _matches(r, case.may_change)]
    if lost:
        found.append(("lost file", "changed or removed: " + ", ".join(lost[:5])))
    for r in results:
        if any(m in r.stderr for m in _MEMORY):
            found.append(("unbounded memory", _report_line(r.stderr)))
            break
        if r.signal in (signal.SIGKILL, signal.SIGSEGV, signal.SIGABRT) and r.maxrss_mb > 0.9 * (
            case_mem_mb()
        ):
            found.append(("unbounded memory", f"killed by signal {r.signal} at the limit"))
            break
    for r in results:
        if r.rc is None:
            what = (f"Ctrl-C not honoured within {r.grace_s:.0f} s" if r.sigint_late
                    else f"no end within {r.limit_s:.0f} s")  # fmt: skip
            found.append(("hang", what))
            break
    if any(t in stderr for t in _TRACE):
        found.append(("traceback", _report_line(stderr)))
    elif any(r.signal is not None for r in results if r.rc == -1):
        sig = next(r.signal for r in results if r.rc == -1)
        found.append(("traceback", f"died of signal {sig}"))
    allowed = case.outputs if success else (*case.error_outputs, *_partial_outputs(case))
    new = [rel for rel in after if rel not in before]
    if not success:  # what the steps that did finish wrote may stay
        done = {a for r, s in zip(results, case.steps, strict=False) if r.rc == 0 for a in s}
        allowed = (*allowed, *(p for p in case.outputs if p in done or p.split("/")[0] in done))
    if success and case.expect == "error":  # "silent" covers the run's ordinary outputs
        stray = [rel for rel in new if _hidden(rel, ())]
    else:
        stray = [rel for rel in new if not _matches(rel, allowed) or _hidden(rel, allowed)]
    stray = [rel for rel in stray if not any(rel.startswith(s + "/") for s in stray)]
    stray = [rel for rel in stray if rel != MARKER and not _empty_tree(cdir / rel)]
    tmp_left = [p.relative_to(tmp).as_posix() for p in tmp.iterdir() if p.name != ".mpl"]
    if stray or tmp_left:
        found.append(
            ("leftover", "new: " + ", ".join((stray + [f"$TMPDIR/{t}" for t in tmp_left])[:5]))
        )
    running = [p for r in results for p in r.left_running]
    if running:
        found.append(("leftover", "still running after the run: " + ", ".join(running[:5])))
    kept = [rel for rel, d in after.items() if success and d != "dir" and _matches(rel, case.gone)]
    if kept:
        found.append(("leftover", "an earlier run's temporary not removed: " + kept[0]))
    finished = last.rc is not None
    warned = bool(re.search(r"^W dexlfd", stderr, re.M))
    if success:
        if case.expect == "error":
            found.append(("silent", "exit 0" + (" (with a warning)" if warned else "")))
        elif case.expect == "complain" and not warned:
            found.append(("silent", "exit 0 without a warning"))
        missing = [p for p in case.outputs if "*" not in p and not (cdir / p).exists()]
        if case.expect == "ok" and missing:
            found.append(("unclear", "exit 0 but missing " + ", ".join(missing)))
    elif finished and last.rc in (1, 2):
        line = _error_line(last.stderr)
        if case.expect == "ok" and last.rc == 1:
            found.append(("refused", line or _report_line(last.stderr)))
        elif not line:
            found.append(("unclear", f"exit {last.rc} without an error line: "
                          f"{_report_line(last.stderr)}"))  # fmt: skip
        elif case.needles and not any(n.lower() in line.lower() for n in case.needles):
            found.append(("unclear", f"error line names none of {list(case.needles)}: {line}"))
        elif case.expect == "ok":
            found.append(("refused", line))
    elif finished and last.rc == 128 + case.stop_signal and case.sigint_after is not None:
        words = {signal.SIGINT: "interrupted", signal.SIGTERM: "terminated",
                 signal.SIGHUP: "hung up"}.get(case.stop_signal, "")  # fmt: skip
        if words not in last.stderr:
            found.append(("unclear", f"exit {last.rc} without the '{words}' line"))
    elif finished and last.rc not in (-1,):
        found.append(("unclear", f"exit {last.rc}: {_report_line(last.stderr)}"))
    order = {c: i for i, c in enumerate(CLASSES)}
    found.sort(key=lambda cd: order.get(cd[0], 99))
    cls, detail = found[0] if found else ("clean", _report_line(last.stderr))
    return Outcome(case, cls, detail, results, [c for c, _ in found[1:]])


def _partial_outputs(case: Case) -> tuple[str, ...]:
    """What a simulate/teleop run cut short may keep: its rollout, or NAME.partial.npz."""
    if case.command not in ("simulate", "teleop"):
        return ()
    argv = case.steps[-1]
    out = [argv[i + 1] for i, a in enumerate(argv[:-1]) if a in ("-o", "--output")]
    if not out:
        return ()
    name = out[-1]
    stem = name[:-4] if name.endswith(".npz") else name
    return (name, f"{stem}.partial.npz")


def _empty_tree(path: Path) -> bool:
    """A folder holding no file (a named output folder made before the run failed)."""
    if path.is_symlink() or not path.is_dir():
        return False
    return not any(p.is_file() or p.is_symlink() for p in path.rglob("*"))


_MEM_MB = [3072.0]


def case_mem_mb() -> float:
    return _MEM_MB[0]


# --------------------------------------------------------------------------- report


def table(outcomes: list[Outcome]) -> str:
    classes = [c for c in CLASSES if any(o.cls == c for o in outcomes)] or ["clean"]
    if any(o.cls == "skipped" for o in outcomes):
        classes.append("skipped")
    cmds = [c for c in COMMANDS if any(o.case.command == c for o in outcomes)]
    width = max(10, *(len(c) for c in classes))
    head = f"{'command':<12}" + "".join(f"{c:>{width + 1}}" for c in classes) + f"{'total':>7}"
    lines = [head, "-" * len(head)]
    for cmd in [*cmds, "all"]:
        sel = [o for o in outcomes if cmd == "all" or o.case.command == cmd]
        row = f"{cmd:<12}" + "".join(
            f"{sum(o.cls == c for o in sel):>{width + 1}}" for c in classes
        )
        lines.append(row + f"{len(sel):>7}")
    return "\n".join(lines)


def nonclean(rows: list[dict[str, Any]]) -> str:
    """Every case that did not end cleanly, grouped by class and subcommand."""
    lines: list[str] = []
    for cls in CLASSES[1:]:
        sel = [r for r in rows if r["class"] == cls]
        if not sel:
            continue
        lines.append(f"== {cls} ({len(sel)})")
        for cmd in COMMANDS:
            for r in (r for r in sel if r["command"] == cmd):
                lines.append(f"  {r['id']}: {' && '.join(r['argv'])[:300]}")
                lines.append(f"      -> {r['detail'][:300]}")
    return "\n".join(lines)


def render(report: Path) -> str:
    """The table and the non-clean list of an earlier sweep's sweep.json."""
    rows = json.loads(report.read_text())["cases"]
    classes = [c for c in (*CLASSES, "skipped") if any(r["class"] == c for r in rows)]
    cmds = [c for c in COMMANDS if any(r["command"] == c for r in rows)]
    width = max(10, *(len(c) for c in classes))
    head = f"{'command':<12}" + "".join(f"{c:>{width + 1}}" for c in classes) + f"{'total':>7}"
    lines = [head, "-" * len(head)]
    for cmd in [*cmds, "all"]:
        sel = [r for r in rows if cmd == "all" or r["command"] == cmd]
        counts = "".join(f"{sum(r['class'] == c for r in sel):>{width + 1}}" for c in classes)
        lines.append(f"{cmd:<12}{counts}{len(sel):>7}")
    return "\n".join(lines) + "\n\n" + nonclean(rows)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    parser.add_argument("-o", "--output", type=Path, default=None,
                        help="folder for sweep.json and table.txt (default: a new temporary "
                        "folder)")  # fmt: skip
    parser.add_argument("--filter", default="", help="run only cases whose id matches this "
                        "regular expression")  # fmt: skip
    parser.add_argument("--jobs", type=int, default=1, help="cases at once (default: 1)")
    parser.add_argument("--memory-gb", type=float, default=3.0,
                        help="address-space limit of each case (default: 3)")  # fmt: skip
    parser.add_argument("--data", type=Path, default=REPO / ".." / "shared" / "data",
                        help="folder with a real hand video (human_hand_video.mp4); cases "
                        "that need it are skipped without it")  # fmt: skip
    parser.add_argument("--list", action="store_true", help="list the case ids and exit")
    parser.add_argument("--render", type=Path, default=None, metavar="SWEEP_JSON",
                        help="print the table and the non-clean cases of a run")  # fmt: skip
    args = parser.parse_args(argv)
    if args.render is not None:
        print(render(args.render))
        return 0
    if args.jobs < 1:
        parser.error("--jobs must be >= 1")
    out = args.output or Path(tempfile.mkdtemp(prefix="dexlfd-sweep-"))
    if out.resolve().is_relative_to(REPO.resolve()):
        parser.error(f"-o {out}: the sweep never writes into the repository")
    out.mkdir(parents=True, exist_ok=True)
    for k, v in {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
                 "NUMBA_NUM_THREADS": "1", "MPLBACKEND": "Agg"}.items():  # fmt: skip
        os.environ.setdefault(k, v)
    os.environ.setdefault("MUJOCO_GL", "egl")
    work = Path(tempfile.mkdtemp(prefix="dexlfd-sweep-work-"))
    os.chmod(work, 0o755)
    _MEM_MB[0] = args.memory_gb * 1024
    try:
        fx = Fixtures(work / "fx", args.data)
        pattern = re.compile(args.filter) if args.filter else None
        cases = _select(fx, pattern)
        if args.list:
            for c in cases:
                print(f"{c.cid}\t{c.expect}\t{' | '.join(' '.join(s) for s in c.steps)[:150]}")
            return 0
        print(f"{len(cases)} cases; work folder {work}; results to {out}", flush=True)
        _warm(everything=len(cases) > 20)

        t0 = time.monotonic()

        def progress(i: int, o: Outcome) -> None:
            mark = "" if o.cls == "clean" else f"  <-- {o.detail[:150]}"
            secs = sum(r.seconds for r in o.results)
            print(f"[{len(seen) + 1:4d}/{len(cases)} {time.monotonic() - t0:6.0f}s] "
                  f"{o.cls:<16} {secs:5.1f}s {o.case.cid}{mark}", flush=True)  # fmt: skip
            seen.append(i)

        seen: list[int] = []
        runner = Runner(work, fx, int(args.memory_gb * GB), args.jobs)
        outcomes = runner.run_all(cases, progress)
        text = table(outcomes)
        (out / "table.txt").write_text(text + "\n", errors="backslashreplace")
        (out / "sweep.json").write_text(json.dumps(
            {"cases": [o.as_json() for o in outcomes],
             "counts": {c: sum(o.cls == c for o in outcomes) for c in (*CLASSES, "skipped")}},
            indent=1))  # fmt: skip
        (out / "nonclean.txt").write_text(nonclean([o.as_json() for o in outcomes]) + "\n",
                                          errors="backslashreplace")  # fmt: skip
        print(text)
        print(f"wrote {out / 'sweep.json'}, {out / 'table.txt'} and {out / 'nonclean.txt'}")
        return 0
    finally:
        shutil.rmtree(work, ignore_errors=True)


def _warm(everything: bool) -> None:
    """Import the commands (``everything``: all of dexlfd's modules) once, for every child."""
    import importlib
    import pkgutil

    import dexlfd
    from dexlfd.cli import _build_parser

    _build_parser()
    if not everything:
        return
    for mod in pkgutil.walk_packages(dexlfd.__path__, "dexlfd."):
        if mod.name.endswith("__main__") or "_lerobot_loader" in mod.name:
            continue
        with contextlib.suppress(Exception):
            importlib.import_module(mod.name)


def _select(fx: Fixtures, pattern: re.Pattern[str] | None) -> list[Case]:
    """The cases to run; the meta-type cases (which read a fixture's keys) only if selected."""
    if pattern is None or any(pattern.search(f"/meta/{k}") for k in FIXTURE_OF):
        cases = all_cases(fx)
    else:
        cases = [
            *flag_cases(), *unit_and_value_cases(), *file_cases(fx, quick_meta=True),
            *wrong_kind_cases(), *source_cases(), *output_cases(), *chain_cases(),
            *misc_cases(), *sigint_cases(), *reliability3_cases(), *recheck_cases(),
        ]  # fmt: skip
    return [c for c in cases if pattern is None or pattern.search(c.cid)]


if __name__ == "__main__":
    sys.exit(main())
