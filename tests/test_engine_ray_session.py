"""The engine starts one local Ray cluster per process and reuses it (a module of its own:
it must not meet another module's Ray connection)."""

from __future__ import annotations

from pathlib import Path

import pytest

from dexlfd import engine
from dexlfd.engine import map_items, shutdown_ray


@pytest.mark.slow
def test_local_cluster_started_once_reused_and_shut_down() -> None:
    ray = pytest.importorskip("ray", reason="ray is not installed")
    if ray.is_initialized():
        pytest.skip("this process already has a Ray connection")
    try:
        try:
            first = map_items(abs, [-1, 2, -3], labels=["a", "b", "c"], engine="ray", workers=2)
        except Exception as exc:  # any reason Ray cannot start here is a skip, with the reason
            pytest.skip(f"cannot start a local Ray cluster: {exc}")
        assert [o.value for o in first] == [1, 2, 3]
        node = ray.get_runtime_context().get_node_id()
        session = Path(engine._own_ray["temp_dir"])
        assert session.is_dir()
        # a second call with no more workers reuses the running cluster
        again = map_items(abs, [-4], labels=["d"], engine="ray", workers=1)
        assert again[0].value == 4 and ray.get_runtime_context().get_node_id() == node
        # more workers than it has: a new cluster, the old one's files removed
        bigger = map_items(abs, [-5], labels=["e"], engine="ray", workers=3)
        assert bigger[0].value == 5 and ray.get_runtime_context().get_node_id() != node
        assert not session.exists()
        session = Path(engine._own_ray["temp_dir"])
    finally:
        shutdown_ray()
    assert not ray.is_initialized() and not session.exists()
    shutdown_ray()  # a second call is a no-op
