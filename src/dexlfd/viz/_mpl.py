"""Lazy matplotlib import with the non-interactive Agg backend and a clear error.

:func:`save_figure` writes a figure as ``savefig(..., bbox_inches="tight")`` does, from
one drawing instead of two: ``savefig`` draws the whole figure once (without pixels) to
find the bounding box of what is drawn, then again at that size. Here the figure is
drawn once, its bounding box is asked of that drawing and the pixels are cut to it (the
padding the canvas lacks filled with the figure's colour). About 0.1 s of CPU less per
figure (15-20 %, ``benchmarks/teach_results.md``); the image has the same size, its
content at most half a pixel shifted, except a legend of the whole figure: ``savefig``
places it again within the cut (plan.png's, centred under the cut, moves a few
pixels), here it stays where the layout put it. A figure whose content reaches past its
canvas (a legend pushed outside) is saved by ``savefig``, which can enlarge it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.errors import DependencyNotInstalled

__all__ = ["envelope_indices", "pyplot", "save_figure"]


def pyplot() -> Any:
    """Return ``matplotlib.pyplot`` using the Agg backend (no display needed)."""
    try:
        import matplotlib
    except ImportError as exc:  # pragma: no cover - matplotlib is a dependency
        raise DependencyNotInstalled("matplotlib", "plotting") from exc
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig: Any, path: str | Path, dpi: int = 120) -> Path:
    """Save ``fig`` atomically as PNG, cut to what is drawn (``bbox_inches="tight"``); close it."""
    from dexlfd.io import atomic_write

    path = Path(path)
    try:
        atomic_write(path, lambda fh: _write_tight_png(fig, dpi, fh))
    finally:
        pyplot().close(fig)
    return path


def _write_tight_png(fig: Any, dpi: int, fh: Any) -> None:
    """Write to ``fh`` what ``fig.savefig(fh, format="png", dpi=dpi, bbox_inches="tight")`` does.

    Drawn once (see the module docstring).
    """
    import matplotlib as mpl
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
    fig.set_dpi(dpi)
    canvas.draw()
    tight = fig.get_tightbbox(canvas.get_renderer())
    width, height = fig.get_size_inches()
    if tight.x0 < 0 or tight.y0 < 0 or tight.x1 > width or tight.y1 > height:
        fig.savefig(fh, format="png", dpi=dpi, bbox_inches="tight")  # it draws what is outside
        return
    pad = mpl.rcParams["savefig.pad_inches"]
    x0, y0, x1, y1 = (float(v) * dpi for v in tight.padded(pad).extents)
    rgba = np.asarray(canvas.buffer_rgba())
    rows, cols = rgba.shape[:2]
    # savefig's canvas: int(size) pixels, its bottom-left corner at (x0, y0); rows count
    # down from the top, y up from the bottom (the cut is within half a pixel of it)
    shape = (int(y1 - y0), int(x1 - x0), 4)
    top, left = round(rows - y0) - shape[0], round(x0)
    image = np.empty(shape, np.uint8)
    image[...] = np.round(255 * np.asarray(mpl.colors.to_rgba(fig.get_facecolor())))
    r0, c0 = max(top, 0), max(left, 0)
    r1, c1 = min(top + shape[0], rows), min(left + shape[1], cols)
    image[r0 - top : r1 - top, c0 - left : c1 - left] = rgba[r0:r1, c0:c1]
    metadata = {"Software": f"Matplotlib version{mpl.__version__}, https://matplotlib.org/"}
    mpl.image.imsave(fh, image, format="png", dpi=dpi, metadata=metadata)


def envelope_indices(y: FloatArray, n_bins: int) -> np.ndarray:
    """Indices of ``y`` that draw as ``y`` does at ``n_bins`` columns: each column's extremes.

    ``y`` (n,) is cut into at most ``n_bins`` runs of equal length; kept are each run's
    smallest and largest sample (a spike keeps its peak), the first and the last sample
    and every NaN that starts a gap (the line stays broken there), in order. With
    ``n_bins`` at least the pixel columns the curve spans, each column shows the same
    extent; ``y`` shorter than ``2 * n_bins`` is kept whole.
    """
    y = np.asarray(y, dtype=float)
    n = y.shape[0]
    if n <= 2 * n_bins:
        return np.arange(n)
    run = -(-n // n_bins)
    m = -(-n // run)
    gaps = np.isnan(y)
    low = np.full(m * run, np.inf)
    high = np.full(m * run, -np.inf)
    low[:n] = np.where(gaps, np.inf, y)
    high[:n] = np.where(gaps, -np.inf, y)
    starts = np.arange(m) * run
    keep = [starts + low.reshape(m, run).argmin(axis=1),
            starts + high.reshape(m, run).argmax(axis=1),
            np.flatnonzero(gaps & ~np.r_[False, gaps[:-1]]), [0, n - 1]]  # fmt: skip
    return np.unique(np.minimum(np.concatenate(keep), n - 1).astype(np.intp))
