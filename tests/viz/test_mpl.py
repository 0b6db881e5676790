"""The figure writer (one drawing, cut as ``bbox_inches="tight"`` cuts) and the envelope
a 1 kHz series is drawn from."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest

from dexlfd.viz._mpl import envelope_indices, pyplot, save_figure


def test_envelope_keeps_each_bins_extremes_a_spike_and_the_ends() -> None:
    rng = np.random.default_rng(3)
    y = np.sin(np.linspace(0, 20, 21_001)) + 0.05 * rng.normal(size=21_001)
    y[7_777], y[12_345] = 9.0, -7.0  # one-sample spikes
    keep = envelope_indices(y, 500)
    assert keep.size <= 2 * 500 + 2 < y.size / 10
    assert np.all(np.diff(keep) > 0)  # in time order, each sample once
    assert {0, 7_777, 12_345, y.size - 1} <= set(keep.tolist())
    # every run of 42 samples keeps its lowest and highest: the drawn extent is the same
    run = -(-y.size // 500)
    for start in range(0, y.size, run):
        part = y[start : start + run]
        mine = y[keep[(keep >= start) & (keep < start + run)]]
        assert mine.min() == part.min() and mine.max() == part.max()


def test_envelope_keeps_a_short_series_whole_and_a_gap_broken() -> None:
    np.testing.assert_array_equal(envelope_indices(np.arange(10.0), 5), np.arange(10))
    y = np.cos(np.linspace(0, 3, 5_000))
    y[2_000:2_300] = np.nan
    kept = y[envelope_indices(y, 100)]
    assert np.isnan(kept).sum() >= 1  # the line is broken where the samples are missing
    assert np.nanmax(kept) == np.nanmax(y) and np.nanmin(kept) == np.nanmin(y)


def _figure(legend_outside: bool):
    plt = pyplot()
    fig, axes = plt.subplots(2, 1, figsize=(5, 4))
    t = np.linspace(0, 5, 400)
    axes[0].plot(t, np.sin(t), label="sin")
    axes[1].plot(t, np.cos(t) * 1e3, label="cos")
    axes[1].set_xlabel("t [s]")
    fig.suptitle("two panels")
    if legend_outside:  # past the canvas's right edge: the cut must grow the image
        axes[0].legend(loc="upper left", bbox_to_anchor=(1.05, 1.0))
    else:  # the labels at the canvas's edges, the cut's padding beyond them
        axes[1].legend(loc="lower left")
        fig.tight_layout(pad=0.02)
    return fig


def _blocks(image: np.ndarray, k: int = 4) -> np.ndarray:
    """``image`` (h, w, c) as the means of its k x k blocks."""
    h, w = (n - n % k for n in image.shape[:2])
    return image[:h, :w].reshape(h // k, k, w // k, k, -1).mean(axis=(1, 3))


@pytest.mark.parametrize("legend_outside", [False, True])
def test_save_figure_writes_the_png_savefig_tight_writes(tmp_path: Path, legend_outside) -> None:
    from PIL import Image

    reference = io.BytesIO()
    _figure(legend_outside).savefig(reference, format="png", dpi=90, bbox_inches="tight")
    path = save_figure(_figure(legend_outside), tmp_path / "f.png", dpi=90)
    with Image.open(path) as im:
        im.verify()  # a whole, valid PNG
    mine = np.asarray(Image.open(path).convert("RGBA"), dtype=float)
    theirs = np.asarray(Image.open(reference).convert("RGBA"), dtype=float)
    assert mine.shape == theirs.shape
    # the same picture, at most half a pixel shifted: only the edges' anti-aliasing and
    # the text's hinting differ, which 4x4-pixel means hide (~0.7 here; the picture two
    # pixels off: 2-4)
    assert np.abs(_blocks(mine) - _blocks(theirs)).mean() < 1.5
    assert not list(tmp_path.glob("*part*"))  # written atomically
