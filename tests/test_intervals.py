"""The one grasp-interval helper: runs of a flag in samples and in seconds."""

from __future__ import annotations

import numpy as np

from dexlfd.intervals import grasp_intervals, longest_run, true_runs

T = np.arange(10) * 0.125  # exact in binary: ties are ties
FLAGS = np.array([1, 1, 0, 0, 1, 1, 1, 0, 0, 1], bool)


def test_runs_in_samples_end_exclusive() -> None:
    assert true_runs(FLAGS) == [(0, 2), (4, 7), (9, 10)]
    assert true_runs(np.zeros(4, bool)) == []
    assert true_runs(np.ones(3, bool)) == [(0, 3)]


def test_intervals_end_where_the_hand_opens_or_at_the_last_closed_sample() -> None:
    opened = grasp_intervals(T, FLAGS)
    np.testing.assert_allclose(opened, [(0.0, 0.25), (0.5, 0.875), (1.125, 1.125)])
    last = grasp_intervals(T, FLAGS, until="last")
    np.testing.assert_allclose(last, [(0.0, 0.125), (0.5, 0.75), (1.125, 1.125)])


def test_longest_run_prefers_the_earlier_of_equals_and_can_skip_the_ends() -> None:
    assert longest_run(T, FLAGS) == (4, 7)
    tie = np.array([0, 1, 1, 0, 1, 1, 0, 0, 0, 0], bool)
    assert longest_run(T, tie) == (1, 3)
    ends = np.array([1, 1, 1, 1, 0, 1, 0, 1, 1, 1], bool)
    assert longest_run(T, ends) == (0, 4)
    assert longest_run(T, ends, inside=True) == (5, 6)
    assert longest_run(T, np.zeros(10, bool)) is None
    assert longest_run(T, np.ones(10, bool), inside=True) is None
