"""``teach``'s record stage: every source to demonstrations, one per pick-and-place.

A source is a video (tracked with MediaPipe as ``dexlfd record`` does), a landmark
recording (``.npz`` as ``record --save-landmarks`` writes it: the same pipeline without
the tracker) or a demonstration file (``.npz``, used as it is). Each source's
demonstrations go to a folder of their own, ``demos/<name>/<name>-<k>.npz``, and
snapshots of its grasp and release frames, drawn like the record overlay (the recorded
hand's skeleton on the video frame; on a grey canvas for a landmark recording, which has
no pixels), to ``figures/sources/``.

A source in which no pick-and-place is found is named with its verdict and frames
(:func:`source_verdicts`): the run stops before any plan.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from dexlfd.errors import InvalidFile, InvalidInput
from dexlfd.io import Demonstration, atomic_write
from dexlfd.io.demonstration_facts import Quality

if TYPE_CHECKING:
    from collections.abc import Callable

    from dexlfd.apps.record import RecordConfig

__all__ = ["SourceRecord", "record_source", "shrink_for_snapshot", "source_name", "source_verdicts"]

logger = logging.getLogger(__name__)

SNAPSHOT_WIDTH_PX = 640  # frames kept for the snapshots are at most this wide
_JPEG_QUALITY = 85


def source_name(source: str) -> str:
    """The folder name of a source: its file's stem (``webcam:0`` -> ``webcam_0``)."""
    stem = Path(source).stem if Path(source).suffix else ""
    return stem or source.replace(":", "_").replace("/", "_")


def _is_demonstration(source: str) -> bool:
    if Path(source).suffix.lower() != ".npz":
        return False
    from dexlfd.io.kinds import kind_of

    try:
        return kind_of(source) == "demonstration"
    except InvalidFile:
        return False  # a landmark recording is not a dexlfd record file


@dataclass
class SourceRecord:
    """What one source gave: its demonstrations (with verdicts) and files."""

    source: str
    name: str
    demos: list[Demonstration] = field(default_factory=list)
    files: list[Path] = field(default_factory=list)
    snapshots: list[Path] = field(default_factory=list)
    n_frames: int = 0
    detection_rate: float | None = None
    kind: str = "video"
    frames: dict[int, bytes] = field(default_factory=dict, repr=False)  # JPEG per frame

    def summary(self, out: Path) -> dict[str, Any]:
        """JSON-able: the source, its demonstrations and their verdicts."""
        return {
            "source": self.source,
            "name": self.name,
            "kind": self.kind,
            "n_frames": self.n_frames,
            "detection_rate": self.detection_rate,
            "demonstrations": [str(p.relative_to(out)) for p in self.files],
            "pick_and_places": [_episode(d) for d in self.demos],
            "warnings": [w for d in self.demos for w in _quality(d).warnings],
        }


def _quality(demo: Demonstration) -> Quality:
    if demo.quality is not None:
        return demo.quality
    from dexlfd.motion import quality_report

    return quality_report(demo)


def _episode(demo: Demonstration) -> list[int] | None:
    """Recording frames ``[grasp, release]`` of the demonstration's pick-and-place, or None."""
    from dexlfd.learn.events import demonstration_events

    q = demo.quality
    if q is not None and q.pick_and_place is None:
        return None  # the recording's verdict: no pick-and-place here
    found = demonstration_events(demo.t, demo.grasp)
    if isinstance(found, str):
        return None
    first = int((demo.source_frames or (0, 0))[0])
    return [first + found[0], first + found[1]]


def source_verdicts(records: list[SourceRecord]) -> list[str]:
    """One line per source without any pick-and-place: its name, frames and why."""
    lines = []
    for rec in records:
        if any(_episode(d) is not None for d in rec.demos):
            continue
        warnings = (w.removeprefix("no pick-and-place: ") for d in rec.demos
                    for w in _quality(d).warnings)  # fmt: skip
        why = "; ".join(dict.fromkeys(warnings))
        frames = f"{rec.n_frames} frames" if rec.n_frames else "its frames"
        lines.append(
            f"{rec.source}: no pick-and-place in {frames} "
            f"({why or 'the hand never closed on an object, carried it and opened'})"
        )
    return lines


def record_source(
    source: str,
    cfg: RecordConfig,
    out: Path,
    *,
    name: str | None = None,
    on_frame: Callable[[], object] | None = None,
) -> SourceRecord:
    """Record (or load) ``source``; write its demonstrations and snapshots under ``out``.

    ``on_frame()`` is called after each frame tracked (the tracker built and running).
    """
    from dexlfd.io import load_demonstration, save_demonstration

    name = name or source_name(source)
    folder = out / "demos" / name
    folder.mkdir(parents=True, exist_ok=True)
    for stale in folder.glob("*.npz"):  # an earlier run's demonstrations of this source
        stale.unlink()
    if _is_demonstration(source):
        demo = load_demonstration(source)
        rec = SourceRecord(source, name, [demo], kind="demonstration", n_frames=demo.n_samples)
    else:
        rec = _record(source, cfg, name, on_frame)
    for k, demo in enumerate(rec.demos, start=1):
        path = folder / (f"{name}.npz" if len(rec.demos) == 1 else f"{name}-{k}.npz")
        rec.files.append(save_demonstration(path, demo))
    return rec


def _record(
    source: str, cfg: RecordConfig, name: str, on_frame: Callable[[], object] | None = None
) -> SourceRecord:
    """Track ``source``; keep the frames (JPEG in memory) for the snapshots.

    Each frame is shrunk and encoded in a thread beside the tracker (OpenCV lets go of
    the GIL): about 3.4 ms of CPU a 1080p frame (:func:`shrink_for_snapshot`), which ran
    between two tracked frames.
    """
    import sys

    from tqdm import tqdm

    from dexlfd.apps.record import record_demonstration

    is_landmarks = Path(source).suffix.lower() == ".npz"

    def tracked(_i: int, _t: float) -> None:
        bar.update(1)
        if on_frame is not None:
            on_frame()

    with _FrameKeeper() as keeper, tqdm(
        desc=name, disable=not sys.stderr.isatty(), leave=False, unit="frame"
    ) as bar:  # fmt: skip
        res = record_demonstration(
            source, cfg, on_frame=None if is_landmarks else keeper.keep,
            callback=tracked, n_frames_hint=lambda n: bar.reset(total=n),
        )  # fmt: skip
        frames = keeper.frames()
    demos = list(res.demos or (res.demo,))
    return SourceRecord(
        source, name, demos, n_frames=res.n_frames, detection_rate=res.detection_rate,
        kind="landmarks" if is_landmarks else "video", frames=frames,
    )  # fmt: skip


class _FrameKeeper:
    """Video frames shrunk to :data:`SNAPSHOT_WIDTH_PX` and JPEG-encoded in a thread."""

    MAX_PENDING = 8  # frames waiting for the thread (a full-size copy each)

    def __init__(self) -> None:
        from concurrent.futures import ThreadPoolExecutor

        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="dexlfd-snapshots")
        self._pending: list[tuple[int, Any]] = []
        self._done: dict[int, bytes] = {}

    def __enter__(self) -> _FrameKeeper:
        return self

    def __exit__(self, *exc: object) -> None:
        for _, future in self._pending:
            future.cancel()
        self._pool.shutdown(wait=True)

    def keep(self, frame: Any, _res: Any) -> None:
        """Queue ``frame`` (its pixels copied: the reader may reuse them)."""
        while len(self._pending) >= self.MAX_PENDING:
            self._collect_oldest()
        rgb = np.array(frame.rgb, copy=True)
        self._pending.append((int(frame.index), self._pool.submit(_encode_snapshot, rgb)))

    def _collect_oldest(self) -> None:
        index, future = self._pending.pop(0)
        buf = future.result()
        if buf is not None:
            self._done[index] = buf

    def frames(self) -> dict[int, bytes]:
        """Every kept frame's JPEG by frame index (waits for the thread)."""
        while self._pending:
            self._collect_oldest()
        return self._done


def shrink_for_snapshot(rgb: np.ndarray, width: int = SNAPSHOT_WIDTH_PX) -> np.ndarray:
    """``rgb`` (H, W, 3) at most ``width`` wide: halved by area while twice as wide, then linear.

    Every frame of a video is shrunk (any may turn out to be a grasp or a release), so
    the cost counts: OpenCV's area resize is fast by exactly two (a 2x2 mean) and slow
    by other factors (1920 -> 640: 4.3 ms of CPU a frame, 1.3 s over a 10 s clip, taken
    from the tracking's second core). Halving while the frame is at least twice
    ``width``, then one linear step, costs 1.7 ms at 1080p and stays within 35 dB PSNR
    of the area resize (an image of text and fine noise; a nearest or a linear resize
    straight to ``width`` alias to 24 dB). A frame already no wider is returned as is.
    """
    import cv2

    h, w = rgb.shape[:2]
    if w <= width:
        return rgb
    target = (int(width), max(1, round(h * width / w)))
    while rgb.shape[1] >= 2 * width and rgb.shape[0] >= 2 * target[1]:
        rgb = cv2.resize(rgb, (rgb.shape[1] // 2, rgb.shape[0] // 2), interpolation=cv2.INTER_AREA)
    if rgb.shape[1] == target[0] and rgb.shape[0] == target[1]:
        return rgb
    return cv2.resize(rgb, target, interpolation=cv2.INTER_LINEAR)


def _encode_snapshot(rgb: np.ndarray) -> bytes | None:
    """``rgb`` at most :data:`SNAPSHOT_WIDTH_PX` wide as JPEG bytes (None if it fails).

    Converted to BGR by ``cvtColor``: a reversed-channel view costs the encoder three
    times as much as the copy (2.2 against 0.7 ms at 640x360).
    """
    import cv2

    bgr = cv2.cvtColor(shrink_for_snapshot(rgb), cv2.COLOR_RGB2BGR)
    ok, buf = cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, _JPEG_QUALITY])
    return buf.tobytes() if ok else None


def write_snapshots(rec: SourceRecord, folder: Path) -> list[Path]:
    """PNGs of each pick-and-place's grasp and release frame, drawn like the record overlay."""
    import cv2

    from dexlfd.viz.capture import draw_skeleton

    frames, rec.frames = rec.frames, {}
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for k, demo in enumerate(rec.demos, start=1):
        episode = _episode(demo)
        if episode is None:
            continue
        first = int((demo.source_frames or (0, 0))[0])
        for what, frame in zip(("grasp", "release"), episode, strict=True):
            img = _frame_image(demo, frames.get(frame))
            local = frame - first
            uv = demo.extras.get("uv_px")
            if uv is not None and 0 <= local < demo.n_samples:
                size = demo.image_size or img.shape[1::-1]
                uv_k = np.asarray(uv[local], dtype=np.float64) * (img.shape[1] / size[0])
                img = draw_skeleton(img, uv_k, f"{rec.name}: {what} {k}, frame {frame}")
            ok, buf = cv2.imencode(".png", img[:, :, ::-1])
            if not ok:
                continue
            path = folder / f"{rec.name}_{k}_{what}.png"
            data = buf.tobytes()
            atomic_write(path, lambda fh, data=data: fh.write(data))
            paths.append(path)
    rec.snapshots = paths
    return paths


def _frame_image(demo: Demonstration, jpeg: bytes | None) -> np.ndarray:
    """The kept frame (RGB), or a grey canvas of the recording's size (no pixels)."""
    import cv2

    if jpeg is not None:
        bgr = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR)
        if bgr is not None:
            return np.ascontiguousarray(bgr[:, :, ::-1])
    size = demo.image_size or (640, 480)
    w, h = int(size[0]), int(size[1])
    if w > SNAPSHOT_WIDTH_PX:
        w, h = SNAPSHOT_WIDTH_PX, round(h * SNAPSHOT_WIDTH_PX / w)
    return np.full((h, w, 3), 60, dtype=np.uint8)


def check_sources(sources: list[str]) -> None:
    """InvalidInput for a source file that does not exist or cannot be read (before any work)."""
    for s in sources:
        low = s.lower()
        if low.startswith(("webcam:", "webcams:", "videos:", "realsense")):
            continue
        if not Path(s).exists():
            what = "landmark recording or demonstration" if low.endswith(".npz") else "video"
            raise InvalidInput(f"{s}: no such {what} file")
        if low.endswith(".npz") and not _is_demonstration(s):  # damaged: said before any file
            from dexlfd.capture.landmark_recording import load_landmark_recording

            load_landmark_recording(s)
