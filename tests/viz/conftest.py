"""Checks of drawn figures shared by the viz tests: legends clear of data, 3-D labels clear
of ticks, equal aspect."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pytest


def _display_points(ax: Any) -> list[tuple[str, np.ndarray]]:
    """Every plotted data point of ``ax`` in display pixels, named by its artist's label.

    Lines (their vertices, through their own transform: a blended ``axhline`` is where it
    is drawn) and scatter offsets; 3-D lines projected the way the axes drew them.
    """
    from matplotlib.collections import PathCollection

    out: list[tuple[str, np.ndarray]] = []
    is_3d = getattr(ax, "name", "") == "3d"
    for line in ax.get_lines():
        if not line.get_visible():
            continue
        if is_3d:
            from mpl_toolkits.mplot3d import proj3d

            xs, ys, zs = (np.asarray(v, float) for v in line.get_data_3d())
            x2, y2, _ = proj3d.proj_transform(xs, ys, zs, ax.get_proj())
            xy = ax.transData.transform(np.column_stack([x2, y2]))
        else:
            xy = line.get_transform().transform(np.asarray(line.get_xydata(), float))
        out.append((str(line.get_label()), xy))
    for coll in ax.collections:
        if isinstance(coll, PathCollection) and coll.get_visible() and not is_3d:
            xy = coll.get_offset_transform().transform(np.asarray(coll.get_offsets(), float))
            out.append((str(coll.get_label()), xy))
    return out


def legend_data_overlaps(fig: Any) -> list[str]:
    """Where a legend's box covers a plotted data point of any axes in ``fig``.

    The figure is drawn first (legend placement and 3-D projections happen then);
    one line per (legend, artist) with the number of points covered.
    """
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    legends = [ax.get_legend() for ax in fig.axes if ax.get_legend()] + list(fig.legends)
    hits = []
    for legend in legends:
        box = legend.get_window_extent(renderer)
        names = [t.get_text() for t in legend.get_texts()]
        for ax in fig.axes:
            for label, xy in _display_points(ax):
                ok = np.isfinite(xy).all(axis=1)
                x, y = xy[ok].T
                inside = (x > box.x0) & (x < box.x1) & (y > box.y0) & (y < box.y1)
                if inside.any():
                    hits.append(f"legend {names} covers {int(inside.sum())} point(s) of {label!r}")
    return hits


def _overlap(a: Any, b: Any) -> bool:
    return bool(a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1)


def label_tick_overlaps_3d(fig: Any) -> list[str]:
    """Where a 3-D axis label overlaps a tick label or another axis label."""
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    hits = []
    for ax in fig.axes:
        if getattr(ax, "name", "") != "3d":
            continue
        axes3 = (ax.xaxis, ax.yaxis, ax.zaxis)
        labels = [(a.label.get_text(), a.label.get_window_extent(r)) for a in axes3]
        ticks = [
            (t.label1.get_text(), t.label1.get_window_extent(r))
            for a in axes3
            for t in a.get_major_ticks()
            if t.label1.get_visible() and t.label1.get_text()
        ]
        for i, (name, box) in enumerate(labels):
            hits += [f"{name!r} over tick {t!r}" for t, tb in ticks if _overlap(box, tb)]
            hits += [f"{name!r} over {o!r}" for o, ob in labels[i + 1 :] if _overlap(box, ob)]
    return hits


def unequal_aspect(ax: Any, rtol: float = 0.01) -> str | None:
    """None when one data unit is as long on x as on y on screen, else by how much not."""
    ax.figure.canvas.draw()
    (x0, y0), (x1, y1) = ax.transData.transform([(0.0, 0.0), (1.0, 1.0)])
    sx, sy = abs(x1 - x0), abs(y1 - y0)
    return None if abs(sx - sy) <= rtol * max(sx, sy) else f"x {sx:.1f} px/unit, y {sy:.1f}"


@pytest.fixture
def legend_overlaps() -> Callable[[Any], list[str]]:
    """:func:`legend_data_overlaps`."""
    return legend_data_overlaps


@pytest.fixture
def label_overlaps_3d() -> Callable[[Any], list[str]]:
    """:func:`label_tick_overlaps_3d`."""
    return label_tick_overlaps_3d


@pytest.fixture
def aspect_error() -> Callable[..., str | None]:
    """:func:`unequal_aspect`."""
    return unequal_aspect
