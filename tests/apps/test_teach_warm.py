"""``teach``'s warm-up beside ``record``: it only loads earlier what the stages load.

The warm-up thread starts at the first tracked frame, runs once and is waited for;
a plan and a rollout made while it runs (or after it) are the ones made without it,
to the bit.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

from dexlfd.apps.teach_warm import SWITCH_INTERVAL_S, WarmUp
from dexlfd.cli import main

from ._teach_sources import write_camera_demos


def test_the_warm_up_runs_once_in_a_thread_and_the_block_waits_for_it() -> None:
    ran: list[str] = []
    release = threading.Event()
    before = sys.getswitchinterval()

    def work() -> None:
        release.wait(timeout=10)
        # the tracking thread gets the GIL back sooner while this runs
        assert sys.getswitchinterval() == min(before, SWITCH_INTERVAL_S) < before
        ran.append(threading.current_thread().name)

    with WarmUp(work) as warm:
        for _ in range(3):  # once a frame: only the first starts it
            warm.start()
        assert ran == []  # still running beside this thread
        release.set()
    assert ran == ["dexlfd-warm-up"]  # its check of the interval passed
    assert sys.getswitchinterval() == before


def test_a_warm_up_never_started_does_nothing_and_a_failed_one_is_no_error() -> None:
    ran: list[int] = []
    with WarmUp(lambda: ran.append(1)):
        pass
    assert ran == []

    def fails() -> None:
        raise RuntimeError("no kernels here")

    with WarmUp(fails) as warm:
        warm.start()  # the stages load what they need themselves


def test_recording_a_source_calls_on_frame_once_a_tracked_frame(
    shared_data: Path, tmp_path: Path
) -> None:
    from dexlfd.apps.record import RecordConfig
    from dexlfd.apps.teach_sources import record_source

    path = shared_data / "landmarks" / "llama.npz"
    if not path.is_file():
        pytest.skip(f"real landmark recording not found at {path}")
    calls: list[int] = []
    rec = record_source(str(path), RecordConfig(), tmp_path, on_frame=lambda: calls.append(1))
    assert rec.n_frames > 0 and len(calls) == rec.n_frames


_REPLAY = """
import json, sys
from pathlib import Path
import numpy as np
from dexlfd.apps import teach
from dexlfd.apps.teach_robot import simulate_plan, teach_plan
from dexlfd.apps.teach_warm import SWITCH_INTERVAL_S, WarmUp
from dexlfd.io import load_model

out, mode, dest = Path(sys.argv[1]), sys.argv[2], sys.argv[3]
frame = json.loads((out / "manifest.json").read_text())["frame"]
with WarmUp() as warm:
    if mode == "beside":
        warm.start()  # plan and simulate while the warm-up loads the same modules and kernels
    placement = teach._placement(frame["summary"]["placement"])
    plan, _ = teach_plan(load_model(out / "model.npz"), placement)
    cfg = teach.TeachConfig(sources=("x",))
    rollout = simulate_plan(plan, cfg, teach._object_size(frame))
np.savez(dest, t=plan.t, position=plan.position, quaternion=plan.quaternion,
         rollout_t=rollout.t, q=rollout.q, tau=rollout.tau)
"""


@pytest.mark.slow
@pytest.mark.integration
def test_a_plan_and_rollout_made_beside_the_warm_up_are_the_cold_ones(tmp_path) -> None:
    from dexlfd.io import load_plan, load_rollout

    sources = write_camera_demos(tmp_path / "takes", n=4, seed=0)
    out = tmp_path / "out"
    assert main(["teach", *map(str, sources), "-o", str(out), "-q"]) == 0
    assert json.loads((out / "manifest.json").read_text())["simulate"]
    plan, rollout = load_plan(out / "plan.npz"), load_rollout(out / "rollout.npz")
    for mode in ("cold", "beside"):  # each in a fresh process: nothing loaded before
        dest = tmp_path / f"{mode}.npz"
        subprocess.run([sys.executable, "-c", _REPLAY, str(out), mode, str(dest)], check=True,
                       env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)})  # fmt: skip
        with np.load(dest, allow_pickle=False) as got:
            for key, want in (("t", plan.t), ("position", plan.position),
                              ("quaternion", plan.quaternion), ("rollout_t", rollout.t),
                              ("q", rollout.q), ("tau", rollout.tau)):  # fmt: skip
                np.testing.assert_array_equal(got[key], want, err_msg=f"{mode}: {key}")
