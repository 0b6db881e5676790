"""Load a LeRobot dataset with ``lerobot`` itself and print what it returns as JSON.

Run by the interpreter of the LeRobot environment (:mod:`dexlfd.io._lerobot_env`),
not imported by dexlfd: ``python _lerobot_loader.py DATASET_DIR`` prints one JSON
object (timings [s], fps, counts, every frame's numeric features and, for each
camera, the shape of its decoded frames and their mean per channel in [0, 1]).
"""

import json
import sys
import time

import numpy as np


def main(root: str) -> None:
    """Open ``root`` with ``LeRobotDataset`` and dump every frame."""
    t0 = time.perf_counter()
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    t1 = time.perf_counter()
    ds = LeRobotDataset("dexlfd/export", root=root)
    t2 = time.perf_counter()
    cameras = set(ds.meta.camera_keys)
    frames: dict[str, list] = {}
    images: dict[str, dict[str, list]] = {k: {"shape": [], "mean": []} for k in cameras}
    tasks = []
    for i in range(len(ds)):
        item = ds[i]
        for key, value in item.items():
            if key == "task":
                tasks.append(value)
            elif key in cameras:
                pixels = np.asarray(value.numpy(), dtype=np.float64)  # (channels, h, w)
                images[key]["shape"].append(list(pixels.shape))
                images[key]["mean"].append(pixels.reshape(pixels.shape[0], -1).mean(1).tolist())
            elif hasattr(value, "numpy"):
                frames.setdefault(key, []).append(np.asarray(value.numpy()).tolist())
    t3 = time.perf_counter()
    out = {
        "lerobot_version": __import__("lerobot").__version__,
        "import_s": t1 - t0,
        "open_s": t2 - t1,
        "iterate_s": t3 - t2,
        "fps": ds.fps,
        "num_episodes": ds.num_episodes,
        "num_frames": ds.num_frames,
        "features": sorted(ds.features),
        "tasks": tasks,
        "episode_ranges": [
            [
                int(ds.meta.episodes[e]["dataset_from_index"]),
                int(ds.meta.episodes[e]["dataset_to_index"]),
            ]
            for e in range(ds.meta.total_episodes)
        ],
        "stats_keys": sorted(ds.meta.stats) if ds.meta.stats else [],
        "frames": frames,
        "images": images,
        "video_backend": (  # 0.4: video_backend; 0.6: _video_backend
            getattr(ds, "video_backend", None) or getattr(ds, "_video_backend", None)
        )
        if cameras
        else None,
    }
    json.dump(out, sys.stdout)


if __name__ == "__main__":
    main(sys.argv[1])
