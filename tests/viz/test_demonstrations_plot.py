from __future__ import annotations

from pathlib import Path

from dexlfd.viz.demonstrations import plot_demonstrations


def test_plot_writes_png(tmp_path: Path, demos) -> None:
    out = plot_demonstrations(demos, tmp_path / "d.png")
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
