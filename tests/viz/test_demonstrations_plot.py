from __future__ import annotations

from pathlib import Path

from dexlfd.viz.demonstrations import plot_demonstrations


def test_plot_writes_png(tmp_path: Path, demos) -> None:
    out = plot_demonstrations(demos, tmp_path / "d.png")
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def _overlap(a, b) -> bool:
    return a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1


def test_3d_labels_clear_of_ticks_and_neighbours_title_names_files(demos) -> None:
    """No 3-D axis label overlaps a tick label or the channel plots; sources by file name."""
    from dataclasses import replace

    from dexlfd.viz._mpl import pyplot
    from dexlfd.viz.demonstrations import demonstrations_figure

    named = [replace(d, meta={**d.meta, "source": "/a/long/folder/take.npz"}) for d in demos]
    fig = demonstrations_figure(named)
    try:
        fig.canvas.draw()
        r = fig.canvas.get_renderer()
        ax3, *channels = fig.axes
        labels = [a.label.get_window_extent(r) for a in (ax3.xaxis, ax3.yaxis, ax3.zaxis)]
        ticks = [
            t.label1.get_window_extent(r)
            for a in (ax3.xaxis, ax3.yaxis, ax3.zaxis)
            for t in a.get_major_ticks()
            if t.label1.get_visible() and t.label1.get_text()
        ]
        for i, box in enumerate(labels):
            assert not any(_overlap(box, t) for t in ticks), i
            assert not any(_overlap(box, o) for o in labels[i + 1 :]), i
            assert not any(_overlap(box, c.get_tightbbox(r)) for c in channels), i
        title = fig._suptitle.get_text()
        assert "take.npz" in title and "/a/long" not in title
    finally:
        pyplot().close(fig)


def test_one_demonstration_is_titled_in_the_singular(demos) -> None:
    from dexlfd.viz._mpl import pyplot
    from dexlfd.viz.demonstrations import demonstrations_figure

    fig = demonstrations_figure(demos[:1])
    try:
        assert fig._suptitle.get_text().startswith("1 demonstration (source")
    finally:
        pyplot().close(fig)
