from __future__ import annotations

import base64
from pathlib import Path

from dexlfd.viz.demonstrations import plot_demonstrations
from dexlfd.viz.report import Report, Section, write_report


def test_report_embeds_figures_and_escapes(tmp_path: Path, demos) -> None:
    png = plot_demonstrations(demos, tmp_path / "d.png")
    sec = Section(
        "Demos <1>",
        paragraphs=["a & b"],
        figures=[(png, "paths"), (tmp_path / "missing.png", "gone")],
        tables=[(["controller", "E [mm]"], [["pd", 1.23456], ["ntsm-pd", 0.5]], "errors")],
        settings={"k": 6},
    )
    out = write_report(Report("dexlfd", "intro", [sec]), tmp_path / "r.html")
    text = out.read_text()
    assert "Demos &lt;1&gt;" in text and "a &amp; b" in text
    assert base64.b64encode(png.read_bytes()).decode()[:200] in text
    assert "figure missing" in text and "1.235" in text and "&quot;k&quot;: 6" in text
