"""Landmark recordings: the contract, bad input, and `record FILE.npz` (replay)."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from dexlfd.capture.camera_models import Intrinsics
from dexlfd.capture.landmark_log import LandmarkLog
from dexlfd.capture.landmark_recording import (
    LandmarkRecording,
    load_landmark_recording,
    observations_at,
    save_landmark_recording,
    selfie_code,
)
from dexlfd.cli import main
from dexlfd.errors import InvalidFile
from dexlfd.io import load_demonstration

from .landmark_helpers import synthetic_recording


def _arrays(path: Path) -> dict[str, np.ndarray]:
    with np.load(path, allow_pickle=False) as data:
        return {k: data[k] for k in data.files}


def test_a_file_without_meta_loads_and_round_trips(tmp_path: Path) -> None:
    raw = tmp_path / "raw.npz"
    synthetic_recording(raw, n=12)
    rec = load_landmark_recording(raw)
    assert rec.n_frames == 12 and rec.size == (640, 480) and rec.meta == {}
    assert rec.label_selfie.dtype == np.int8 and rec.hands_per_frame.tolist() == [1] * 12
    out = save_landmark_recording(tmp_path / "ours.npz", rec)
    back = load_landmark_recording(out)
    assert back.meta["kind"] == "landmark_recording"
    for name in ("t_s", "image_xyz", "world_xyz_m", "label_selfie", "label_score"):
        np.testing.assert_array_equal(getattr(back, name), getattr(rec, name))
    assert int(_arrays(out)["format_version"]) == 2
    assert back.native_size_px is None and back.intrinsics is None
    assert "facts" not in _arrays(out)  # no fact known: no member


def test_facts_round_trip_typed_and_stay_out_of_meta(tmp_path: Path) -> None:
    raw = tmp_path / "raw.npz"
    synthetic_recording(raw, n=8)
    K = Intrinsics(640, 480, 600.0, 610.0, 319.5, 239.5)
    rec = replace(
        load_landmark_recording(raw),
        native_size_px=(1280, 960),
        intrinsics=K,
        meta={"source": "cam", "native_size_px": [1, 1]},  # a stale copy is not written
    )
    out = save_landmark_recording(tmp_path / "ours.npz", rec)
    back = load_landmark_recording(out)
    assert back.native_size_px == (1280, 960) and back.intrinsics == K
    assert back.meta["source"] == "cam"
    assert "native_size_px" not in back.meta and "intrinsics" not in back.meta
    facts = json.loads(str(_arrays(out)["facts"]))
    assert facts["native_size_px"] == [1280, 960] and facts["intrinsics"]["fy"] == 610.0


def _version_1(path: Path, meta: dict[str, Any]) -> Path:
    """A version-1 file: the facts kept in its meta (as dexlfd wrote them before)."""
    arrays = _arrays(path)
    arrays["format_version"] = np.asarray(1)
    arrays["meta"] = np.asarray(json.dumps({"kind": "landmark_recording", **meta}))
    np.savez(path, **arrays)
    return path


def test_a_version_1_file_has_its_facts_lifted_from_meta(tmp_path: Path) -> None:
    raw = tmp_path / "v1.npz"
    synthetic_recording(raw, n=8)
    K = {"width": 640, "height": 480, "fx": 500.0, "fy": 500.0, "cx": 320, "cy": 240}
    _version_1(raw, {"source": "s", "native_size_px": [1280, 960], "intrinsics": K})
    rec = load_landmark_recording(raw)
    assert rec.native_size_px == (1280, 960)
    assert rec.intrinsics == Intrinsics(640, 480, 500.0, 500.0, 320.0, 240.0)
    assert rec.meta == {"kind": "landmark_recording", "source": "s"}  # provenance only
    # that version never checked them: unusable ones are ignored, as it did
    _version_1(raw, {"native_size_px": [0, 5], "intrinsics": {"fx": 1}})
    rec = load_landmark_recording(raw)
    assert rec.native_size_px is None and rec.intrinsics is None


def test_bad_facts_are_one_line_naming_the_entry(tmp_path: Path) -> None:
    raw = tmp_path / "raw.npz"
    synthetic_recording(raw, n=8)
    arrays = _arrays(raw)
    arrays["format_version"] = np.asarray(2)
    arrays["facts"] = np.asarray(json.dumps({"native_size_px": [640, "x"]}))
    np.savez(raw, **arrays)
    with pytest.raises(InvalidFile, match=r"facts\.native_size_px\[1\]"):
        load_landmark_recording(raw)
    arrays["facts"] = np.asarray(json.dumps({"native_size_px": [0, 480]}))
    np.savez(raw, **arrays)
    with pytest.raises(InvalidFile, match="native_size_px must be a positive"):
        load_landmark_recording(raw)
    K = {"width": 640, "height": 480, "fx": -5.0, "fy": 500.0, "cx": 320, "cy": 240}
    arrays["facts"] = np.asarray(json.dumps({"intrinsics": K}))
    np.savez(raw, **arrays)
    with pytest.raises(InvalidFile, match="facts.intrinsics: fx"):
        load_landmark_recording(raw)


def test_labels_name_the_persons_hand() -> None:
    rec_path_free = LandmarkRecording(
        t_s=np.array([0.0]),
        image_xyz=np.full((1, 2, 21, 3), 0.5),
        world_xyz_m=np.zeros((1, 2, 21, 3)),
        label_selfie=np.array([[0, 1]], np.int8),
        label_score=np.array([[0.9, 0.8]]),
        frame_size_px=np.array([200, 100]),
    )
    # MediaPipe's selfie "Left" is the person's right hand on an unmirrored image
    obs = observations_at(rec_path_free, 0, mirrored=False)
    assert [o.handedness for o in obs] == ["right", "left"]
    np.testing.assert_allclose(obs[0].uv_px, np.tile([100.0, 50.0], (21, 1)))
    assert [o.handedness for o in observations_at(rec_path_free, 0, mirrored=True)] == [
        "left",
        "right",
    ]
    # the inverse: writing gives back the stored selfie codes, either way
    for mirrored in (False, True):
        back = observations_at(rec_path_free, 0, mirrored)
        assert [selfie_code(o, mirrored) for o in back] == [0, 1]
    log = LandmarkLog(mirrored=False)
    log.add(0.0, obs, (200, 100))
    log.add(0.1, [], (200, 100))
    made = log.recording()
    assert made.label_selfie.tolist() == [[0, 1], [-1, -1]]
    np.testing.assert_allclose(made.image_xyz[0], rec_path_free.image_xyz[0])
    assert np.isnan(made.image_xyz[1]).all()


def _broken(arrays: dict[str, np.ndarray], case: str) -> dict[str, np.ndarray]:
    a = dict(arrays)
    if case == "shape":
        a["image_xyz"] = a["image_xyz"][:, :, :20]
    elif case == "nan":
        a["image_xyz"] = a["image_xyz"].copy()
        a["image_xyz"][3, 0, 5, 0] = np.nan
    elif case == "world_nan":
        a["world_xyz_m"] = a["world_xyz_m"].copy()
        a["world_xyz_m"][4, 0, 0, 2] = np.nan
    elif case == "label":
        a["label_selfie"] = a["label_selfie"].copy()
        a["label_selfie"][2, 1] = 2
    elif case == "time":
        a["t_s"] = a["t_s"].copy()
        a["t_s"][5] = a["t_s"][4]
    elif case == "size":
        a["frame_size_px"] = np.array([640, 0])
    elif case == "giant-frame":  # a unit slip: no video has a frame this size
        a["frame_size_px"] = np.array([10**9, 10**9])
    elif case == "missing":
        del a["label_score"]
    elif case == "score":
        a["label_score"] = a["label_score"] * 3
    elif case == "milliseconds":
        a["t_s"] = a["t_s"] * 1000.0
    elif case == "time-lapse":  # a frame every 2 s
        a["t_s"] = np.arange(a["t_s"].size) * 2.0
    elif case == "millimetres":
        a["world_xyz_m"] = a["world_xyz_m"] * 1000.0
    return a


@pytest.mark.parametrize(
    ("case", "array", "words"),
    [
        ("shape", "image_xyz", "must have shape"),
        ("nan", "image_xyz", "NaN at frame 3, slot 0, where a hand is claimed"),
        ("world_nan", "world_xyz_m", "NaN at frame 4, slot 0"),
        ("label", "label_selfie", "got 2 at frame 2, slot 1"),
        ("time", "t_s", "strictly increasing"),
        ("size", "frame_size_px", "positive (width, height)"),
        ("giant-frame", "frame_size_px", "of at most 16384 px, got [1000000000, 1000000000]"),
        ("missing", "label_score", "missing array"),
        ("score", "label_score", "in [0, 1]"),
        ("milliseconds", "t_s", "must be in seconds of a video at >= 1 frame/s (milliseconds?"),
        ("time-lapse", "t_s", "median frame step of 2 s (0.5 frames/s)"),
        ("millimetres", "world_xyz_m", "within 0.5 m (millimetres?)"),
    ],
)
def test_bad_arrays_name_the_file_and_the_array(
    tmp_path: Path, capsys, case: str, array: str, words: str
) -> None:
    good = tmp_path / "good.npz"
    synthetic_recording(good, n=10)
    bad = tmp_path / f"{case}.npz"
    np.savez(bad, **_broken(_arrays(good), case))
    with pytest.raises(InvalidFile) as err:
        load_landmark_recording(bad)
    msg = str(err.value)
    assert str(bad) in msg and f"'{array}'" in msg and words in msg and "\n" not in msg
    out = tmp_path / "d.npz"
    assert main(["record", str(bad), "-o", str(out)]) == 1
    lines = [ln for ln in capsys.readouterr().err.splitlines() if "error" in ln.lower()]
    assert len(lines) == 1 and array in lines[0] and str(bad) in lines[0]
    assert "Traceback" not in lines[0] and not out.exists()


def test_foreign_and_corrupt_files(tmp_path: Path) -> None:
    text = tmp_path / "notes.npz"
    text.write_text("not a zip")
    good = tmp_path / "good.npz"
    synthetic_recording(good, n=10)
    cut = tmp_path / "cut.npz"
    cut.write_bytes(good.read_bytes()[:500])
    for path in (text, cut):
        with pytest.raises(InvalidFile, match="not a readable .npz"):
            load_landmark_recording(path)
    pickled = tmp_path / "pickled.npz"
    arrays = _arrays(good)
    arrays["label_score"] = np.array([object()] * 10, dtype=object)
    np.savez(pickled, **arrays)
    with pytest.raises(InvalidFile, match="not a readable"):  # never unpickled
        load_landmark_recording(pickled)
    with pytest.raises(InvalidFile, match="no such file"):
        load_landmark_recording(tmp_path / "absent.npz")
    other = tmp_path / "demo_like.npz"
    np.savez(other, meta=np.asarray('{"kind": "demonstration"}'), **_arrays(good))
    with pytest.raises(InvalidFile, match="is a 'demonstration' file"):
        load_landmark_recording(other)


@pytest.mark.parametrize("with_meta", [False, True])
def test_record_a_landmark_file_lifts_the_known_hand(tmp_path: Path, with_meta: bool) -> None:
    src = tmp_path / "hand.npz"
    wrist, t = synthetic_recording(src, n=60, with_meta=with_meta)
    out = tmp_path / "d.npz"
    argv = ["record", str(src), "-o", str(out), "--smoothing", "none", "--no-trim"]
    assert main(argv) == 0
    demo = load_demonstration(out)
    np.testing.assert_allclose(demo.t, t)
    assert demo.valid.all() and demo.capture.source_kind == "landmarks"
    assert demo.capture.to_json()["hand_choice"]["hand"] == "right"
    K = demo.capture.to_json()["intrinsics"]
    assert (K["width"], K["height"]) == (640, 480) and K["approximate"]
    # an exact rigid hand: the whole-recording pose puts the wrist where it was (camera
    # frame) to a few mm (its smoother's motion prior rounds the start: 3.2 mm at 0.6 m)
    np.testing.assert_allclose(demo.keypoints[:, 0], wrist, atol=5e-3)


def test_re_processing_with_other_intrinsics(tmp_path: Path, capsys) -> None:
    src = tmp_path / "hand.npz"
    wrist, _ = synthetic_recording(src, n=40, hfov_deg=60.0)
    K60 = 320 / np.tan(np.radians(30))
    fx = K60 / 2  # a camera with half the focal length: the same pixels are half as far
    out = tmp_path / "d.npz"
    argv = ["record", str(src), "-o", str(out), "--smoothing", "none", "--no-trim"]
    assert main([*argv, "--intrinsics", f"{fx},{fx},319.5,239.5"]) == 0
    demo = load_demonstration(out)
    assert demo.capture.to_json()["intrinsics"]["fx"] == pytest.approx(fx)
    # not exact (the perspective differs), but about half as far
    np.testing.assert_allclose(demo.keypoints[:, 0, 2], wrist[:, 2] / 2, rtol=0.06)
    out2 = tmp_path / "d2.npz"
    assert main([*argv[:3], str(out2), "--fov-deg", "90", "--no-trim"]) == 0
    K = load_demonstration(out2).capture.to_json()["intrinsics"]
    assert K["fx"] == pytest.approx(320.0)  # 90 deg over 640 px


def test_intrinsics_of_another_image_size_are_refused(tmp_path: Path, capsys) -> None:
    # a 10x10 px image's K on 640x480 frames: every hand would be lifted to a wrong place
    src = tmp_path / "hand.npz"
    synthetic_recording(src, n=10)
    out = tmp_path / "d.npz"
    assert main(["record", str(src), "-o", str(out), "--intrinsics", "10,10,5,5"]) == 1
    err = capsys.readouterr().err
    assert (
        "--intrinsics: the principal point (5, 5) px is far from the centre of the 640x480" in err
    )
    assert "Traceback" not in err and not out.exists()


def test_landmark_source_refuses_what_needs_images(tmp_path: Path, capsys) -> None:
    src = tmp_path / "hand.npz"
    synthetic_recording(src, n=10)
    out = tmp_path / "d.npz"
    assert main(["record", str(src), "-o", str(out), "--overlay", str(tmp_path / "o.mp4")]) == 1
    err = capsys.readouterr().err
    assert "--overlay" in err and "no images" in err and not out.exists()
    assert main(["record", str(src), "-o", str(out), "--resize-width-px", "320"]) == 1
    err = capsys.readouterr().err
    assert "--resize-width-px" in err and "landmark recording" in err and not out.exists()
    assert main(["record", str(tmp_path / "absent.npz"), "-o", str(out)]) == 1
    assert "no such landmark recording" in capsys.readouterr().err


def test_save_landmarks_then_replay_gives_the_same_demonstration(tmp_path: Path, capsys) -> None:
    from dexlfd.data import hand_video

    video = str(hand_video())
    lms, a, b = tmp_path / "L.npz", tmp_path / "a.npz", tmp_path / "b.npz"
    common = ["--max-frames", "45", "--resize-width-px", "640", "--intrinsics", "900,900,640,360"]
    assert main(["record", video, "--save-landmarks", str(lms), "-o", str(a), *common]) == 0
    assert str(lms) in capsys.readouterr().err  # listed among the files written
    rec = load_landmark_recording(lms)
    assert rec.n_frames == 45 and rec.size == (640, 360)
    assert rec.native_size_px == (1280, 720) and rec.meta["kind"] == "landmark_recording"
    assert "native_size_px" not in rec.meta  # a typed fact, not meta
    assert rec.meta["tracker"]["max_num_hands"] == 2
    # the real right hand is MediaPipe's "Left" (selfie convention) in the raw labels
    assert (rec.label_selfie[:, 0] == 0).all()
    assert main(["record", str(lms), "-o", str(b), "--intrinsics", "900,900,640,360"]) == 0
    da, db = load_demonstration(a), load_demonstration(b)
    np.testing.assert_allclose(db.t, da.t)
    for name in ("keypoints", "position", "quaternion", "gripper"):
        np.testing.assert_allclose(getattr(db, name), getattr(da, name), atol=1e-9)
    np.testing.assert_array_equal(db.grasp, da.grasp)
    assert db.capture.to_json()["intrinsics"] == da.capture.to_json()["intrinsics"]
    assert db.quality.usable == da.quality.usable
    # a landmark recording is not saved again, and the flag never overwrites an input
    again = str(tmp_path / "x.npz")
    assert main(["record", str(lms), "-o", str(b), "--save-landmarks", again]) == 1
    assert "--save-landmarks" in capsys.readouterr().err and not (tmp_path / "x.npz").exists()
    assert main(["record", video, "-o", str(b), "--save-landmarks", video]) == 1
    assert "--save-landmarks" in capsys.readouterr().err


def test_several_sources_save_landmarks_into_a_folder(tmp_path: Path) -> None:
    import argparse

    from dexlfd._commands import record as record_cmd
    from dexlfd.apps.record import RecordConfig

    videos = [tmp_path / "a.mp4", tmp_path / "b.mp4"]
    for v in videos:
        v.write_bytes(b"")
    args = argparse.Namespace(
        source=[str(v) for v in videos], output=str(tmp_path / "demos"), overlay=None,
        plot=None, rerun=None, save_landmarks=str(tmp_path / "lms"),
    )  # fmt: skip
    jobs = record_cmd._jobs(args, RecordConfig())
    assert [Path(j.output).name for j in jobs] == ["a.npz", "b.npz"]
    assert [j.save_landmarks for j in jobs] == [
        str(tmp_path / "lms" / "a_landmarks.npz"),
        str(tmp_path / "lms" / "b_landmarks.npz"),
    ]


def test_hostile_landmark_files_give_invalid_file_only(tmp_path: Path) -> None:
    """Random mutations of a valid file: a checked recording or one InvalidFile line."""
    from hypothesis import HealthCheck, Phase, given, settings
    from hypothesis import strategies as st

    good = tmp_path / "good.npz"
    synthetic_recording(good, n=6)
    base = _arrays(good)
    values = st.sampled_from(
        [np.nan, np.inf, -1.0, 0.0, 2.0, 1e300, "x", b"\x00", [1, 2], object()]
    )

    @settings(
        max_examples=60, deadline=None, derandomize=True, database=None,
        phases=[Phase.explicit, Phase.generate],
        suppress_health_check=[HealthCheck.function_scoped_fixture],
    )  # fmt: skip
    @given(
        name=st.sampled_from(sorted(base)),
        how=st.sampled_from(["value", "shape", "dtype", "drop", "bytes"]),
        value=values,
        seed=st.integers(0, 10_000),
    )
    def check(name: str, how: str, value: object, seed: int) -> None:
        rng = np.random.default_rng(seed)
        arrays = dict(base)
        a = arrays[name].astype(np.float64)  # so any number fits
        if how == "value" and a.size and isinstance(value, float):
            a.reshape(-1)[rng.integers(a.size)] = value
            arrays[name] = a
        elif how == "shape":
            arrays[name] = a.reshape(-1)[: max(0, a.size - 1)]
        elif how == "dtype":
            arrays[name] = np.array([value] * max(1, a.size % 7), dtype=object)
        elif how == "drop":
            del arrays[name]
        path = tmp_path / f"case{seed}.npz"
        if how == "bytes":
            path.write_bytes(good.read_bytes()[: int(rng.integers(0, 4000))])
        else:
            try:
                np.savez(path, **arrays)
            except (TypeError, ValueError):
                return
        try:
            rec = load_landmark_recording(path)
        except InvalidFile as exc:
            assert str(path) in str(exc) and "\n" not in str(exc)
            return
        assert np.isfinite(rec.image_xyz[rec.label_selfie >= 0]).all()
        assert (np.diff(rec.t_s) > 0).all() and (rec.frame_size_px > 0).all()

    check()
