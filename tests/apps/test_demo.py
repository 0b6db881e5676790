"""End-to-end: synthetic hands -> motion -> learn -> plan -> simulated Panda -> report."""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from dexlfd.apps.demo import DemoConfig, run_demo
from dexlfd.io import load_model, load_plan, load_rollout
from dexlfd.io.rosbag import read_rosbag

SRC = Path(__file__).resolve().parents[2] / "src"


@pytest.mark.integration
def test_demo_runs_end_to_end_and_resumes(tmp_path: Path, session_processes) -> None:
    """``dexlfd demo -o DIR``, exactly as the README gives it (the README test leaves the
    command to this one): every stage, the report, no process of it left once it has
    exited (its pools' fork servers), then a resume that reuses every stage and a changed
    setting that reruns only the stage it feeds."""
    out = tmp_path / "demo"
    path = os.pathsep.join(filter(None, [str(SRC), os.environ.get("PYTHONPATH")]))
    env = {**os.environ, "PYTHONPATH": path}
    cmd = [sys.executable, "-m", "dexlfd", "demo", "-o", str(out)]
    logs = tmp_path / "stdout.txt", tmp_path / "stderr.txt"
    with logs[0].open("w") as stdout_f, logs[1].open("w") as stderr_f:  # files, not pipes
        proc = subprocess.Popen(cmd, env=env, stdout=stdout_f, stderr=stderr_f,
                                text=True, start_new_session=True)  # fmt: skip
        proc.wait(timeout=3600)
    stdout, stderr = (f.read_text() for f in logs)
    assert proc.returncode == 0, stderr[-2000:]
    # its pools' fork servers and resource trackers were stopped and waited for: once it
    # has exited, nothing of its session is left, not even a zombie
    left = session_processes(proc.pid)
    assert not left, left
    assert stdout.strip() == f"report: {out / 'report.html'}"
    cfg = DemoConfig()  # the command's settings: its flags' defaults are the config's
    # the small pick/place grid: planned, simulated and placed within 2 cm
    grid = json.loads((out / "generalize" / "generalize.json").read_text())
    assert [r["success_rate"] for r in grid["summary"]] == [1.0]
    assert (out / "generalize" / "generalize.png").is_file()
    # the demo's own model (six demonstrations) and all four controllers: a smaller model
    # once hid joint-velocity safety stops that only the executed Table 5.1 plan reaches
    model = load_model(out / "model.npz")
    assert model.meta["settings"]["n_components"] == "auto"  # K from held-out likelihood
    assert model.meta["n_demonstrations"] == 6 and model.extras["aligned"].shape[0] == 6
    for name in ("alignment", "dtw_correspondence", "dtw_example", "gmm", "gmr", "quality"):
        assert (out / "figures" / "learn" / f"{name}.png").is_file()
    plan = load_plan(out / "plans" / "task.npz")
    # the executed plan clears the 0.4 m cup with the object under the TCP
    assert plan.position[:, 2].max() > 0.4 + cfg.plan_margin
    for controller in cfg.controllers:  # every controller ran the plan to its end
        ran = load_rollout(out / "control" / f"{controller}_1.2kg.npz")
        assert ran.stopped is None, (controller, ran.stopped)
    ro = load_rollout(out / "control" / "ntsm-pd_1.2kg.npz")
    assert ro.extras["attached"].any()  # the object was really picked up
    err = np.linalg.norm(ro.ee_position - ro.ref_position, axis=1)
    assert err.max() < 0.05  # NTSM-PD with an unknown 1.2 kg: centimetre-level at worst
    assert (out / "robot.mp4").stat().st_size > 0
    assert "/joint_states" in read_rosbag(out / "export" / "rollout_bag")
    html = (out / "report.html").read_text()
    assert "SYNTHETIC" in html and "Table 5.1" in html and "<video" in html
    assert "Capture" in html  # the real hand video's section

    # a rerun reuses every finished stage; a changed setting reruns the stage it feeds
    manifest = json.loads((out / "manifest.json").read_text())
    rerun = run_demo(cfg, out)
    assert rerun.summary["seconds"] == {k: round(v["seconds"], 1) for k, v in manifest.items()}
    control_rows = rerun.summary["control"]
    loaded = [r["controller"] for r in control_rows if r["payload_kg"] == cfg.payload_kg]
    assert sorted(loaded) == sorted(cfg.controllers)
    run_demo(dataclasses.replace(cfg, video_fps=cfg.video_fps / 2), out)
    after = json.loads((out / "manifest.json").read_text())
    assert after["video"] != manifest["video"]
    assert {k: v for k, v in after.items() if k != "video"} == {
        k: v for k, v in manifest.items() if k != "video"
    }
