"""LeRobotDataset v3.0 export and import of demonstrations and rollouts (pyarrow only).

Layout written (LeRobot's ``codebase_version`` ``"v3.0"``)::

    DIR/meta/info.json                           fps, features, totals, path templates
    DIR/meta/stats.json                          min/max/mean/std/count (+ quantiles) per feature
    DIR/meta/tasks.parquet                       task string (pandas index) -> task_index
    DIR/meta/episodes/chunk-000/file-000.parquet one row per episode
    DIR/data/chunk-000/file-000.parquet          one row per frame, every episode
    DIR/videos/observation.images.camera/chunk-000/file-000.mp4   (see below)
    DIR/README.md                                the dataset card (``_card``)

The rate is the recordings' own by default (the median of the inputs), 30 fps for
rollouts (simulated at 1 kHz); the task of an episode is its record's own
(:func:`~dexlfd.io.lerobot._write.default_task`: "pick and place", but never for a
recording whose quality report says NOT USABLE) unless one is given for all.

One episode per demonstration or rollout; a dataset holds one kind (their
``observation.state`` differ). Every episode is put on the uniform time grid
``timestamp = frame_index / fps`` that LeRobot requires (its loader checks it to
1e-4 s): an input already on that grid is copied, any other one is resampled
(linear interpolation; spherical for quaternions; nearest sample for flags).

Demonstration features (float32 unless said): ``observation.state`` (8,)
= end-effector ``x, y, z`` [m], ``qx, qy, qz, qw`` (scalar-last), ``gripper`` [m];
``action`` (8,) = the next frame's state (the target the hand moved to; the last
frame repeats itself); ``observation.hand_keypoints`` (63,) = 21 MediaPipe
landmarks × ``x, y, z`` [m], base frame, NaN where unseen (as in the
demonstration); ``observation.hand_visible`` and ``observation.grasp`` (bool).
Where the hand was not seen, state and action are interpolated from the nearest
seen frames (no NaN in them) and ``observation.hand_visible`` is false;
:func:`import_lerobot` restores NaN there. Statistics ignore NaN.

Rollout features: ``observation.state`` (15,) = measured pose + gripper + joint
positions ``panda_joint1..7`` [rad]; ``observation.velocity`` and
``observation.effort`` (7,) [rad/s], [N·m]; ``action`` (8,) = the reference pose
+ gripper the controller tracked.

When every demonstration was recorded from a video file that still exists
(``meta["source"] == "video file PATH"``, ``meta["fps"]``, as ``dexlfd record``
writes them), the frames at the episode's frame times (nearest source frame) are
re-encoded (H.264; resized to ``video_size`` if given) into one MP4, feature
``observation.images.camera``, with
LeRobot's ``videos/<key>/from_timestamp`` / ``to_timestamp`` per episode and the
camera's statistics (per channel, shape (3, 1, 1), intensities in [0, 1], exact over
every frame written; LeRobot's training reads them, e.g. to put ImageNet's in).

Each episode row also carries ``dexlfd/t0`` (the input's first time [s]) and
``dexlfd/meta`` (its ``meta`` as JSON), so an import gives back the original
records. The dataset is written into a temporary sibling folder and renamed: an
interrupted export leaves nothing under the final name.

Modules: ``_schema`` (paths, features, parquet columns, statistics), ``_card`` (the
dataset card), ``_frames``
(records -> frames on the uniform grid), ``_video`` (the episodes' MP4), ``_write``
(:func:`export_lerobot`), ``_read`` (:func:`import_lerobot`).
"""

from __future__ import annotations

from dexlfd.io.lerobot._frames import uniform_grid
from dexlfd.io.lerobot._read import LeRobotEpisodes, import_lerobot, is_lerobot_dataset
from dexlfd.io.lerobot._schema import CODEBASE_VERSION
from dexlfd.io.lerobot._write import (
    MAX_FRAMES,
    check_frames,
    export_lerobot,
    frame_count,
    frame_rate,
)

__all__ = [
    "MAX_FRAMES",
    "check_frames",
    "frame_count",
    "frame_rate",
    "CODEBASE_VERSION",
    "LeRobotEpisodes",
    "export_lerobot",
    "import_lerobot",
    "is_lerobot_dataset",
    "uniform_grid",
]
