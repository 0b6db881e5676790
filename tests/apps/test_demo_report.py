"""The demo report's prose comes from the packaged template, filled from the stage summaries."""

from __future__ import annotations

import html
from importlib import resources
from pathlib import Path

from dexlfd.apps.demo import DemoConfig
from dexlfd.apps.demo_report import build_demo_report, prose


def test_template_is_package_data_and_fills_every_placeholder() -> None:
    assert resources.files("dexlfd.apps").joinpath("templates/demo_report.ini").is_file()
    text = prose("demos", "p1", {"n_demos": 6, "durations_s": [7.9, 8.1]})
    assert text.startswith("6 SYNTHETIC pick-and-place demonstrations")
    assert text.endswith("Durations 7.9, 8.1 s at 30 Hz.") and "  " not in text
    assert "$" not in prose("plan", "p1")  # a missing value reads "none"


def test_prose_says_values_in_words_not_python() -> None:
    """Booleans, None and lists read as words (not 'True', 'None', '[0.1, 0.2]')."""
    text = prose("control", "p2", {"object_carried": True, "best": None})
    assert text == "Object carried: yes. Best of our controllers: none."
    assert prose("control", "p2", {"object_carried": False}).startswith("Object carried: no.")


def test_report_quotes_the_stage_summaries(tmp_path: Path) -> None:
    cfg = DemoConfig(real_video=None)
    results = {
        "demos": {"outputs": {}, "summary": {"n_demos": 2, "durations_s": [1.5, 2.0]}},
        "capture": {"outputs": {}, "summary": {"skipped": "real hand video not found"}},
        "plan": {"outputs": {}, "summary": {
            "goal_errors_mm": [0.42, 0.5, 0.61], "limits_exceeded": [],
            "variance_pair": [{"label": "carry", "displacement_m": 0.07,
                               "beyond_needed_lift_m": 0.005, "variance_level": 0.6,
                               "min_clearance_m": 0.03, "gain": 1.9}],
            "place": {"height_change": -0.0123, "surface_z": 0.09, "release_t": 8.754},
        }},
        "control": {"outputs": {}, "summary": {"best": "ntsm-pd-dob", "rows": [
            {"controller": "pd", "payload_kg": 1.2, "e_nob_mm": 1.0, "e_ob_mm": 3.0,
             "delta_e_mm": 2.0, "delta_ob_pct": 200.0, "max_orientation_error_deg": 0.5,
             "stopped": None}]}},
    }  # fmt: skip
    page = html.unescape(build_demo_report(cfg, tmp_path, results).read_text())
    assert "2 SYNTHETIC pick-and-place demonstrations" in page
    assert "Durations 1.5, 2 s at 30 Hz." in page
    assert "real hand video not found" in page
    assert "starts/goals of §5.3.1: 0.42, 0.5, 0.61 mm" in page
    assert not any(w in page for w in ("True", "False", "None"))
    assert "Cartesian limits exceeded: none." in page
    assert "carry: displacement 0.07 m (0.005 m beyond the needed lift), ν 0.6" in page
    assert "lowered 12.3 mm onto the place table (top z = 0.09 m)" in page
    assert "opens at t = 8.75 s" in page
    assert "an unknown 1.2 kg object (Table 5.1 style)" in page
    assert "Best of our controllers: ntsm-pd-dob." in page
    assert "$" not in page.replace("$(", "")
