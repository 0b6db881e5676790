import numpy as np
import pytest

from dexlfd.errors import InvalidInput
from dexlfd.panda import (
    BASE_RADIUS,
    MIN_REACH,
    REACH,
    SHOULDER,
    check_workspace,
    workspace_violation,
)


@pytest.mark.parametrize(
    ("point", "why"),
    [
        ((0.0, 0.0, SHOULDER[2] + REACH + 0.01), "beyond its reach"),
        ((0.1, 0.0, SHOULDER[2]), "inside the arm itself"),
        ((0.5, 0.1, -0.01), "z must be >= 0.0 m"),
        ((0.0, 0.5 * BASE_RADIUS, 0.1), "inside the robot's base"),
        ((np.nan, 0.0, 0.3), "not a finite position"),
    ],
)
def test_each_rule_names_itself(point, why) -> None:
    bad = workspace_violation(np.array(point))
    assert bad is not None and bad[0] == 0 and why in bad[1]
    with pytest.raises(InvalidInput, match="goal .* outside the Panda's workspace"):
        check_workspace(np.array(point), "goal")


def test_first_offender_is_named_with_its_time() -> None:
    p = np.tile([0.5, 0.0, 0.3], (5, 1))
    assert workspace_violation(p) is None
    check_workspace(p, "plan position", np.arange(5) * 0.1)
    p[3, 2] = -0.2
    p[4, 0] = 2.0
    with pytest.raises(InvalidInput, match=r"plan position 3 \(t=0.300 s\)"):
        check_workspace(p, "plan position", np.arange(5) * 0.1)


def test_reach_bounds_are_inclusive() -> None:
    on_sphere = np.array(SHOULDER) + np.array([REACH, 0.0, 0.0])
    assert workspace_violation(on_sphere) is None
    assert workspace_violation(np.array(SHOULDER) + np.array([MIN_REACH, 0.0, 0.0])) is None
