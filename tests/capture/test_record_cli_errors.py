"""One failed video = one line in the flags' words; no third-party noise; inputs first."""

from __future__ import annotations

from pathlib import Path

from dexlfd.cli import main


def test_a_failed_video_in_a_batch_is_one_translated_line(
    hand_video: Path, tmp_path: Path, capfd
) -> None:
    a, b = tmp_path / "a.mp4", tmp_path / "b.mp4"
    a.write_bytes(hand_video.read_bytes())
    b.write_bytes(hand_video.read_bytes())
    code = main(["record", str(a), str(b), "-o", str(tmp_path / "out"), "--lift", "pinhole"])
    assert code == 1
    err = capfd.readouterr().err
    failed = [line for line in err.splitlines() if "FAILED" in line]
    assert len(failed) == 2 and all("use --lift pnp" in line for line in failed)
    assert "LiftConfig" not in err and "error:" not in err
    assert f"FAILED: {a}" not in err  # the name once per line


def test_a_broken_video_gives_one_line_and_no_ffmpeg_noise(
    hand_video: Path, tmp_path: Path, capfd
) -> None:
    cut = tmp_path / "cut.mp4"
    cut.write_bytes(hand_video.read_bytes()[:50_000])  # no moov atom: ffmpeg complains
    assert main(["record", str(cut), "-o", str(tmp_path / "d.npz"), "--camera-pose", "front"]) == 1
    err = capfd.readouterr().err
    assert err.count("error:") == 1 and "moov" not in err and "W0000" not in err


def test_a_missing_file_comes_before_the_note_about_extrinsics(tmp_path: Path, capfd) -> None:
    assert main(["record", str(tmp_path / "none.mp4"), "-o", str(tmp_path / "d.npz")]) == 1
    err = capfd.readouterr().err
    assert "no such video file" in err and "--extrinsics" not in err
