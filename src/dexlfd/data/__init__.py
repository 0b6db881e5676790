"""Sample data shipped inside the package (found with :mod:`importlib.resources`).

Only files inside this package are ever used: nothing is searched for beside a
source checkout, so an installed ``dexlfd`` finds its samples on any machine.

``human_hand_video.mp4``
    A real RGB video of one human right hand (1280 x 720, 621 frames, 30 fps,
    H.264, no depth) from the dex-retargeting project, MIT licence,
    copyright 2023 Yuzhe Qin; the licence text is ``LICENSE-human_hand_video``
    beside it and provenance is in ``README.md`` of this folder.

``lfo_place_can.webm``
    A real pick-and-place: a person's hand picks a can from a table, carries it
    ~35 cm to the right and sets it down on a tray (640 x 360, 865 frames, 30 fps,
    VP9, no depth; frames 128-992 of the original, cut at its keyframes without
    re-encoding, audio removed) from microsoft/symbolic-robot-teaching-interface,
    MIT licence, copyright Microsoft Corporation; the licence text is
    ``LICENSE-lfo_place_can`` beside it. ``dexlfd teach`` takes it to the robot.

``models/hand_landmarker_{full,lite}.task``
    MediaPipe's hand landmarker bundles (Apache-2.0, ``models/LICENSE-mediapipe``),
    read by :mod:`dexlfd.capture.tracking_tasks`; ``models/README.md`` says how
    they were made.

``panda/``
    franka_ros's Panda description (URDF, collision meshes; Apache-2.0,
    ``panda/LICENSE``), read by :mod:`dexlfd.robot.description`.
"""

from __future__ import annotations

import atexit
import contextlib
from importlib import resources
from pathlib import Path

from dexlfd.errors import InvalidInput

__all__ = ["SAMPLE_FILES", "hand_video", "pick_place_video", "sample_path"]

#: sample file name -> the licence file that must travel with it
SAMPLE_FILES = {
    "human_hand_video.mp4": "LICENSE-human_hand_video",
    "lfo_place_can.webm": "LICENSE-lfo_place_can",
}

_extracted = contextlib.ExitStack()
atexit.register(_extracted.close)


def sample_path(name: str) -> Path:
    """Path on disk of a sample file shipped in :mod:`dexlfd.data`.

    Parameters
    ----------
    name
        File name, one of :data:`SAMPLE_FILES`.

    Returns
    -------
    Path
        The packaged file (normally inside the installed package; if the package
        is imported from a zip archive, a temporary copy removed at exit).

    Raises
    ------
    InvalidInput
        ``name`` is not a sample of this package, or the installation lacks it.
    """
    if name not in SAMPLE_FILES:
        raise InvalidInput(f"unknown sample {name!r}: expected one of {sorted(SAMPLE_FILES)}")
    res = resources.files(__name__) / name
    if not res.is_file():
        raise InvalidInput(f"sample {name!r} is missing from the installed dexlfd.data package")
    if isinstance(res, Path):
        return res
    return Path(_extracted.enter_context(resources.as_file(res)))


def hand_video() -> Path:
    """The packaged real hand video (``human_hand_video.mp4``, MIT, Yuzhe Qin 2023)."""
    return sample_path("human_hand_video.mp4")


def pick_place_video() -> Path:
    """The packaged real pick-and-place video (``lfo_place_can.webm``, MIT, Microsoft).

    One hand picks a can (grasp closed at frame 130 of this file), lifts it, carries
    it ~35 cm to the right and releases it on a tray (frame 663); ``dexlfd teach``
    turns it into a Panda pick-and-place.
    """
    return sample_path("lfo_place_can.webm")
