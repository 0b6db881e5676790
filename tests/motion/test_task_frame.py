"""The task frame from the demonstrations: synthetic scenes with known cameras.

Synthetic pick-and-place demonstrations (base frame, z up) are seen by a camera of
known pose (pitched 20-70 deg down, turned, 0.4-1.0 m from the task) with noise; the
estimate must find up, keep the pick-to-place geometry and round-trip.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from dexlfd.datasets import PickPlaceConfig, pick_place_demonstrations
from dexlfd.errors import InvalidInput
from dexlfd.io import Demonstration
from dexlfd.io.demonstration_facts import CameraIntrinsics, Capture
from dexlfd.motion import TaskFrame, apply_frame, estimate_task_frame, lift_events

CAMERA = "camera (no extrinsics: x right, y down, z forward)"


def camera_to_base(pitch_deg: float, yaw_deg: float, distance_m: float) -> np.ndarray:
    """A camera looking ``pitch_deg`` down, turned ``yaw_deg``, at the task's centre.

    OpenCV camera axes: x right, y down, z forward (the optical axis).
    """
    target = np.array([0.45, 0.0, 0.12])
    th, ps = np.radians(pitch_deg), np.radians(yaw_deg)
    z = np.array([np.cos(th) * np.cos(ps), np.cos(th) * np.sin(ps), -np.sin(th)])
    x = np.cross(z, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    T = np.eye(4)
    T[:3, :3] = np.stack([x, np.cross(z, x), z], axis=1)
    T[:3, 3] = target - distance_m * z
    return T


def to_camera(demos: list[Demonstration], T: np.ndarray) -> list[Demonstration]:
    return [apply_frame(d, np.linalg.inv(T), frame_name=CAMERA) for d in demos]


def _angle_deg(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.degrees(np.arccos(np.clip(np.dot(a, b), -1.0, 1.0))))


def _events(demo: Demonstration) -> tuple[np.ndarray, np.ndarray]:
    (e,) = lift_events(demo)
    return e.grasp_point, e.release_point


CASES = [(20, 10, 0.4), (35, -30, 0.6), (50, 45, 0.8), (70, -80, 1.0)]


@pytest.mark.parametrize(("pitch", "yaw", "dist"), CASES)
def test_up_and_the_pick_to_place_geometry_are_recovered(pitch, yaw, dist) -> None:
    rng = np.random.default_rng(42)
    # a pick 4 cm lower than the place (different heights) and 3 mm position noise
    cfg = PickPlaceConfig(pick=(0.40, -0.20, 0.08), place=(0.50, 0.22, 0.12), position_noise=0.003)
    demos = pick_place_demonstrations(5, rng, cfg)
    T = camera_to_base(pitch, yaw, dist)
    frame = estimate_task_frame(to_camera(demos, T))
    assert isinstance(frame, TaskFrame) and frame.method == "demonstrations"
    up_true = T[:3, :3].T @ np.array([0.0, 0.0, 1.0])
    # the lift leans along the carry; the set-down leans back: a few degrees remain
    assert _angle_deg(frame.up_camera, up_true) < 3.0
    assert frame.uncertainty["up_deg"] > 0 and frame.n_events == 10
    assert abs(frame.details["camera_pitch_deg"] - pitch) < 3.0
    # the task frame differs from the base by a turn about z and a shift (3 deg slack)
    base_to_task = frame.camera_to_task @ np.linalg.inv(T)
    assert base_to_task[2, 2] > np.cos(np.radians(3.0))
    # x is the optical axis made horizontal: the camera's yaw
    x_base = base_to_task[0, :3] @ np.eye(3)
    heading = np.degrees(np.arctan2(base_to_task[0, 1], base_to_task[0, 0]))
    # the optical axis' horizontal part shrinks with the pitch: its turn error grows
    assert abs(((heading - yaw + 180) % 360) - 180) < 2.0 / np.cos(np.radians(pitch)), x_base
    for d_base, d_task in zip(
        demos, [apply_frame(c, frame.camera_to_task) for c in to_camera(demos, T)], strict=True
    ):
        g_b, r_b = _events(d_base)
        g_t, r_t = _events(d_task)
        # distances kept (rigid), the pick on the task frame's table height
        np.testing.assert_allclose(np.linalg.norm(r_t - g_t), np.linalg.norm(r_b - g_b), atol=1e-9)
        assert abs(g_t[2]) < 0.02  # 3 mm noise on 5 demos' picks and a few-degree up error
        # the place is 4 cm higher than the pick, as in the base frame (a 3-deg up error
        # tilts the 45-cm carry by 2.4 cm)
        assert abs((r_t[2] - g_t[2]) - (r_b[2] - g_b[2])) < 0.025
        # the hand lifts: the carry's top is ~30 cm above the pick
        assert np.nanmax(d_task.position[:, 2]) - g_t[2] > 0.25


def test_the_origin_lies_under_the_mean_pick_and_the_camera_height_is_found() -> None:
    rng = np.random.default_rng(42)
    demos = pick_place_demonstrations(4, rng)
    T = camera_to_base(40, 0, 0.7)
    frame = estimate_task_frame(to_camera(demos, T))
    task = [apply_frame(d, frame.camera_to_task) for d in to_camera(demos, T)]
    picks = np.array([_events(d)[0] for d in task])
    np.testing.assert_allclose(picks.mean(axis=0)[:2], 0.0, atol=1e-9)  # under the mean pick
    assert abs(picks.mean(axis=0)[2]) < 0.005  # on the table plane (pick = place height)
    # the camera sits 0.7 sin(40 deg) above the task's centre, the table at z = 0.12
    height = T[2, 3] - np.mean([_events(d)[0][2] for d in demos])
    assert abs(frame.details["camera_height_m"] - height) < 0.02
    assert frame.uncertainty["table_m"] < 0.01


def test_apply_frame_round_trip_and_nan_kept() -> None:
    rng = np.random.default_rng(42)
    (demo,) = pick_place_demonstrations(1, rng)
    valid = demo.valid.copy()
    valid[10:14] = False
    pos = np.where(valid[:, None], demo.position, np.nan)
    quat = np.where(valid[:, None], demo.quaternion, np.nan)
    grip = np.where(valid, demo.gripper, np.nan)
    kp = np.where(valid[:, None, None], rng.normal(0.4, 0.1, (demo.n_samples, 21, 3)), np.nan)
    demo = Demonstration(
        demo.t, kp, valid, pos, quat, grip, demo.grasp, dict(demo.meta), {"depth_std": 0.01 * grip},
        frame=demo.frame,
    )  # fmt: skip
    T = camera_to_base(35, 20, 0.6)
    cam = apply_frame(demo, np.linalg.inv(T), frame_name=CAMERA)
    assert cam.frame == CAMERA and cam.task_frame.scale == 1.0
    back = apply_frame(cam, T, provenance={"method": "test"})
    assert back.frame == "panda_base" and back.task_frame.method == "test"
    assert back.task_frame.from_frame == CAMERA
    np.testing.assert_allclose(back.position, demo.position, atol=1e-12)
    np.testing.assert_allclose(back.keypoints, demo.keypoints, atol=1e-12)
    # q and -q are one rotation: compare up to sign, then check continuity
    dots = np.abs(np.sum(back.quaternion[valid] * demo.quaternion[valid], axis=1))
    np.testing.assert_allclose(dots, 1.0, atol=1e-12)
    q = back.quaternion[valid]
    assert (np.sum(q[1:] * q[:-1], axis=1) > 0).all()
    assert np.isnan(back.position[~valid]).all() and np.isnan(back.quaternion[~valid]).all()
    np.testing.assert_array_equal(back.grasp, demo.grasp)
    np.testing.assert_array_equal(back.gripper, demo.gripper)
    # the scale multiplies positions (and depth spreads) before the transform
    half = apply_frame(demo, T, 0.5)
    np.testing.assert_allclose(half.position, 0.5 * demo.position @ T[:3, :3].T + T[:3, 3])
    np.testing.assert_allclose(half.extras["depth_std"], 0.5 * demo.extras["depth_std"])
    # the input is not changed
    assert demo.frame == "panda_base" and demo.task_frame is None


def test_quaternion_maps_by_the_rotation() -> None:
    from dexlfd.rotations import matrix_from_quat

    rng = np.random.default_rng(42)
    (demo,) = pick_place_demonstrations(1, rng)
    T = camera_to_base(60, -45, 0.9)
    cam = apply_frame(demo, np.linalg.inv(T), frame_name=CAMERA)
    R = T[:3, :3].T
    np.testing.assert_allclose(
        matrix_from_quat(cam.quaternion), R @ matrix_from_quat(demo.quaternion), atol=1e-12
    )


def test_demonstrations_in_a_base_frame_keep_it() -> None:
    demos = pick_place_demonstrations(2, np.random.default_rng(42))
    frame = estimate_task_frame(demos)
    assert frame.method == "extrinsics" and frame.n_events == 4
    np.testing.assert_array_equal(frame.camera_to_task, np.eye(4))
    assert frame.to_dict()["up_camera"] == [0.0, 0.0, 1.0]
    # pick and place at the same height: the grasp and release points are one table
    assert frame.uncertainty["table_m"] < 0.005


def test_no_grasp_is_one_line_naming_the_demonstration() -> None:
    (demo,) = pick_place_demonstrations(1, np.random.default_rng(42))
    T = camera_to_base(40, 0, 0.7)
    (cam,) = to_camera([demo], T)
    open_hand = Demonstration(
        cam.t, cam.keypoints, cam.valid, cam.position, cam.quaternion, cam.gripper,
        np.zeros(cam.n_samples, bool), cam.meta,
    )  # fmt: skip
    with pytest.raises(InvalidInput, match=r"^mug\.npz: no grasp") as info:
        estimate_task_frame([open_hand], names=["mug.npz"])
    assert "\n" not in str(info.value)
    # a grasp held to the recording's end has no release and no close: nothing to use
    held = Demonstration(
        cam.t, cam.keypoints, cam.valid, cam.position, cam.quaternion, cam.gripper,
        np.ones(cam.n_samples, bool), cam.meta,
    )  # fmt: skip
    with pytest.raises(InvalidInput, match="no grasp with a lift"):
        estimate_task_frame([held], names=["held.npz"])


def test_mixed_frames_and_cameras_are_refused() -> None:
    demos = pick_place_demonstrations(2, np.random.default_rng(42))
    T = camera_to_base(40, 0, 0.7)
    cam = to_camera(demos, T)
    with pytest.raises(InvalidInput, match=r"^b\.npz: frame 'panda_base' differs") as info:
        estimate_task_frame([cam[0], demos[1]], names=["a.npz", "b.npz"])
    assert "\n" not in str(info.value)
    other = apply_frame(demos[1], np.linalg.inv(T), frame_name=CAMERA)
    vga = Capture(intrinsics=CameraIntrinsics(640, 480, 500.0, 500.0, 319.5, 239.5))
    hd = Capture(intrinsics=CameraIntrinsics(1920, 1080, 1400.0, 1400.0, 959.5, 539.5))
    a = apply_frame(cam[0], np.eye(4), frame_name=CAMERA)
    with pytest.raises(InvalidInput, match="one camera"):
        estimate_task_frame(
            [replace(a, capture=vga), replace(other, capture=hd)], names=["a.npz", "b.npz"]
        )


def test_bad_transform_and_scale_are_refused() -> None:
    (demo,) = pick_place_demonstrations(1, np.random.default_rng(42))
    with pytest.raises(InvalidInput, match="camera_to_base"):
        apply_frame(demo, np.diag([1.0, 1.0, -1.0, 1.0]))
    with pytest.raises(InvalidInput, match="scale"):
        apply_frame(demo, np.eye(4), 0.0)


def test_an_outlier_run_is_dropped_and_the_sign_comes_from_the_lift() -> None:
    rng = np.random.default_rng(42)
    demos = pick_place_demonstrations(4, rng)
    # one demonstration where the hand slides sideways, 60 deg off vertical, to and fro
    d = demos[0]
    tilt = np.array([[1, 0, 0], [0, 0.5, -np.sqrt(3) / 2], [0, np.sqrt(3) / 2, 0.5]])
    pos = (d.position - d.position[0]) @ tilt.T + d.position[0]
    demos[0] = Demonstration(
        d.t, d.keypoints, d.valid, pos, d.quaternion, d.gripper, d.grasp, d.meta
    )
    T = camera_to_base(45, 0, 0.7)
    frame = estimate_task_frame(to_camera(demos, T))
    kept = [r["kept"] for r in frame.details["runs"]]
    assert kept == [False, True, True, True]
    assert _angle_deg(frame.up_camera, T[:3, :3].T @ [0.0, 0.0, 1.0]) < 3.0
    assert frame.n_events == 6 and frame.details["image_up_agrees"]


def _demo_from_path(p: np.ndarray, grasp: np.ndarray, frame: str = CAMERA) -> Demonstration:
    n = p.shape[0]
    q = np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))
    return Demonstration(
        np.arange(n) / 30.0, np.full((n, 21, 3), np.nan), np.ones(n, bool), p, q,
        np.where(grasp, 0.04, 0.08), grasp, frame=frame,
    )  # fmt: skip


def _arc(pick: np.ndarray, place: np.ndarray, up: np.ndarray, height: float, n: int) -> np.ndarray:
    """A carry that rises along ``up`` by ``height`` [m] over a half sine: symmetric."""
    s = np.linspace(0.0, 1.0, n)[:, None]
    return pick + (place - pick) * s + height * np.sin(np.pi * s) * up


def test_a_symmetric_carry_gives_exactly_up_though_each_side_leans() -> None:
    """Closed form: on a half-sine arc the lift leans towards the place, the set-down
    back towards the pick by the same angle; their unit sum is exactly vertical."""
    up = np.array([0.0, -np.cos(np.radians(40)), -np.sin(np.radians(40))])  # 40 deg down
    pick, place = np.array([-0.1, 0.1, 0.7]), np.array([0.2, 0.15, 0.6])
    place = place - np.dot(place - pick, up) * up  # same height
    carry = _arc(pick, place, up, 0.25, 90)
    p = np.vstack([np.repeat(pick[None], 10, 0), carry, np.repeat(place[None], 10, 0)])
    grasp = np.zeros(p.shape[0], bool)
    grasp[10 : 10 + 90] = True
    demo = _demo_from_path(p, grasp)
    (e,) = lift_events(demo)
    assert e.reason == "" and e.n_events == 2
    assert np.dot(e.lift, place - pick) > 0 and _angle_deg(e.lift / np.linalg.norm(e.lift), up) > 10
    np.testing.assert_allclose(np.linalg.norm(e.lift), np.linalg.norm(e.set_down), rtol=0.05)
    frame = estimate_task_frame([demo])
    assert _angle_deg(frame.up_camera, up) < 0.5  # sampling of the arc only
    assert abs(frame.details["camera_pitch_deg"] - 40.0) < 0.5


def test_a_camera_looking_straight_down_takes_x_from_the_image_and_says_so() -> None:
    rng = np.random.default_rng(42)
    demos = pick_place_demonstrations(3, rng)
    T = camera_to_base(89.9, 0, 0.8)
    frame = estimate_task_frame(to_camera(demos, T))
    assert frame.details["x_axis"].startswith("image up")
    assert abs(frame.details["camera_pitch_deg"] - 90.0) < 3.0
    R = frame.camera_to_task[:3, :3]
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(R) > 0


def _lift_carry_lower(pick: np.ndarray, place: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Hold, lift 12 cm, carry 12 cm above the place, lower, hold (base frame, z up)."""
    from dexlfd.trajectory import minimum_jerk

    up = np.array([0.0, 0.0, 0.12])
    via = [pick, pick, pick + up, place + up, place, place]
    steps = [9, 15, 36, 15, 9]
    parts = [
        a + (b - a) * minimum_jerk(np.linspace(0, 1, n, endpoint=False))[0][:, None]
        for a, b, n in zip(via[:-1], via[1:], steps, strict=True)
    ]
    return np.vstack(parts) + rng.normal(0.0, 0.002, (sum(steps), 3))


def test_shelf_to_shelf_keeps_the_lifts_and_refuses_a_forced_plane() -> None:
    """Picks on a table, places on a shelf 25 cm higher: no single plane fits them."""
    rng = np.random.default_rng(42)
    demos = []
    for k in range(3):
        pick = np.array([0.40 + 0.08 * k, -0.25 + 0.1 * k, 0.05])
        place = np.array([0.55 - 0.05 * k, 0.20 + 0.05 * k, 0.30])
        p = _lift_carry_lower(pick, place, rng)
        grasp = np.zeros(p.shape[0], bool)
        grasp[9:75] = True
        demos.append(_demo_from_path(p, grasp, frame="panda_base"))
    T = camera_to_base(35, 15, 0.8)
    frame = estimate_task_frame(to_camera(demos, T))
    assert not frame.details["plane"]["used"], frame.details["plane"]
    assert _angle_deg(frame.up_camera, T[:3, :3].T @ [0.0, 0.0, 1.0]) < 3.0
    # the places are 25 cm above the picks; the table RMS says the points are not one plane
    assert frame.uncertainty["table_m"] > 0.1
    heights = np.array(frame.details["table_heights_m"])
    np.testing.assert_allclose(heights[:3], 0.0, atol=0.02)  # the picks: the origin's plane
    np.testing.assert_allclose(heights[3:], 0.25, atol=0.03)


def test_rgb_only_depth_widens_the_reported_up_uncertainty() -> None:
    rng = np.random.default_rng(42)
    demos = to_camera(pick_place_demonstrations(3, rng), camera_to_base(30, 0, 0.7))
    exact = estimate_task_frame(demos)
    rgb = [replace(d, capture=Capture(depth="approximate")) for d in demos]
    approx = estimate_task_frame(rgb)
    # the depth error re-weighs the runs by their length across the line of sight
    assert _angle_deg(approx.up_camera, exact.up_camera) < 1.0
    assert approx.details["depth_error_m"] == 0.03 and exact.details["depth_error_m"] == 0.0
    assert approx.uncertainty["up_deg"] > 2 * exact.uncertainty["up_deg"]


def test_the_frame_is_json_and_travels_with_the_saved_demonstration(tmp_path) -> None:
    import json

    from dexlfd.io import load_demonstration, save_demonstration

    rng = np.random.default_rng(42)
    cam = to_camera(pick_place_demonstrations(2, rng), camera_to_base(45, 10, 0.7))
    frame = estimate_task_frame(cam, names=["a.npz", "b.npz"])
    d = frame.to_dict()
    assert json.loads(json.dumps(d)) == d
    assert set(d["uncertainty"]) >= {"up_deg", "scale_rel", "table_m"}
    task = apply_frame(cam[0], frame.camera_to_task, frame.scale, provenance=d)
    save_demonstration(tmp_path / "task.npz", task)
    back = load_demonstration(tmp_path / "task.npz")
    assert back.frame == "panda_base"
    assert back.task_frame.method == "demonstrations"
    np.testing.assert_allclose(back.task_frame.camera_to_base, frame.camera_to_task)
    np.testing.assert_allclose(back.position, task.position)


def test_a_depth_scaled_recording_measures_its_lifts_over_the_same_stretch() -> None:
    """A recording whose depth was multiplied by one factor (the palm read at its full
    size, ``Capture.depth_scale``) has its lifts measured over the same part of the
    motion: every direction, and so up, is what the unscaled recording gives."""
    rng = np.random.default_rng(7)
    T = camera_to_base(35.0, 10.0, 0.9)
    base = _lift_carry_lower(np.array([0.4, -0.1, 0.0]), np.array([0.55, 0.15, 0.0]), rng)
    cam = base @ T[:3, :3] - T[:3, 3] @ T[:3, :3]  # base -> camera
    cam[:, 2] += rng.normal(0.0, 0.01, len(cam))  # RGB-only depth noise along the ray
    grasp = np.zeros(len(cam), bool)
    grasp[9:-9] = True
    plain = _demo_from_path(cam, grasp)
    k = 1.8
    scaled = replace(
        _demo_from_path(k * cam, grasp), capture=Capture(depth="approximate", depth_scale=k)
    )
    (a,) = lift_events(plain)
    (b,) = lift_events(scaled)
    np.testing.assert_allclose(b.lift, k * a.lift, rtol=1e-9)
    np.testing.assert_allclose(b.set_down, k * a.set_down, rtol=1e-9)
    fa, fb = estimate_task_frame([plain]), estimate_task_frame([scaled])
    assert _angle_deg(fa.up_camera, fb.up_camera) < 1e-3
    # without the factor the 10 cm reach covers a shorter part of the lift
    (c,) = lift_events(_demo_from_path(k * cam, grasp))
    assert not np.allclose(c.lift, k * a.lift, rtol=1e-3)


def _pick_place(pick: np.ndarray, place: np.ndarray, lift: np.ndarray, down: np.ndarray):
    """A camera-frame path: rest, move 12 cm along ``lift``, carry, come down along
    ``-down`` onto ``place``, rest; the grasp closed from the move to the place."""

    def line(a: np.ndarray, b: np.ndarray, n: int) -> np.ndarray:
        return a + (b - a) * np.linspace(0.0, 1.0, n)[:, None]

    top_a, top_b = pick + 0.12 * lift, place + 0.12 * down
    p = np.vstack([
        np.repeat(pick[None], 10, 0), line(pick, top_a, 12), line(top_a, top_b, 20),
        line(top_b, place, 12), np.repeat(place[None], 10, 0),
    ])  # fmt: skip
    grasp = np.zeros(p.shape[0], bool)
    grasp[10:54] = True
    return replace(_demo_from_path(p, grasp), capture=Capture(depth="approximate"))


def test_a_pull_along_the_line_of_sight_does_not_outvote_a_lift() -> None:
    """Two runs whose 'lift' is the depth moving along the line of sight (the pixels
    hardly move) and whose set-down points down the image (a slide towards the
    camera), one true lift and lowering: up is the true one, as a person sees it."""
    up = np.array([0.0, -np.cos(np.radians(40)), -np.sin(np.radians(40))])  # 40 deg down
    down_image = np.array([0.0, 0.45, -0.893]) / np.linalg.norm([0.0, 0.45, -0.893])
    demos = []
    for k, pick in enumerate(np.array([[-0.15, 0.05, 0.7], [0.0, 0.08, 0.75], [0.1, 0.0, 0.65]])):
        place = pick + np.array([0.2, 0.0, 0.0])
        if k < 2:
            demos.append(_pick_place(pick, place, -pick / np.linalg.norm(pick), down_image))
        else:
            demos.append(_pick_place(pick, place, up, up))
    frame = estimate_task_frame(demos)
    assert _angle_deg(frame.up_camera, up) < 5.0
    assert abs(frame.details["camera_pitch_deg"] - 40.0) < 5.0
    runs = frame.details["runs"]
    assert [r["kept"] for r in runs] == [False, False, True]
    assert runs[2]["weight_m"] > 2 * max(runs[0]["weight_m"], runs[1]["weight_m"])
