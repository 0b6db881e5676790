"""robot.url: the library names the "robot URL", the CLI says ``--robot``."""

from __future__ import annotations

from pathlib import Path

import pytest

from dexlfd.errors import InvalidInput
from dexlfd.robot.url import parse_robot_url


def test_parse_error_names_the_parameter_and_the_cli_the_flag(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(InvalidInput, match=r"^robot URL franka://HOST needs") as exc:
        parse_robot_url("franka://no host")
    assert "--robot" not in str(exc.value)
    from dexlfd.cli import _build_parser, _subparser, error_text, main
    from dexlfd.io import save_plan
    from dexlfd.plan.moves import lift_plan

    flags = _subparser(_build_parser(), "simulate").get_default("_params")
    far = InvalidInput("the plan starts 120 mm from the arm's TCP", param="approach")
    assert error_text(far, flags) == "--approach: the plan starts 120 mm from the arm's TCP"
    plan = save_plan(tmp_path / "plan.npz", lift_plan(0.5, z_high=0.3))
    out = tmp_path / "r.npz"
    assert main(["simulate", str(plan), "--robot", "franka://no host", "-o", str(out)]) == 1
    err = capsys.readouterr().err
    assert "--robot URL franka://HOST needs an IPv4 address" in err and not out.exists()
