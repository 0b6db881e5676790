"""The parallel engine: same outcomes in process, in a process pool and on Ray."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np
import pytest

from dexlfd.engine import ItemOutcome, format_failures, item_seed, map_items
from dexlfd.errors import InvalidInput

SEED = 20261201
BAD = 3  # the item that raises


def draw(index: int) -> np.ndarray:
    """A random vector from the item's own stream; item ``BAD`` is corrupt."""
    if index == BAD:
        raise InvalidInput(f"item {index} is corrupt\n(second line)")
    return np.random.default_rng(item_seed(SEED, index)).standard_normal(4)


def die_on_two(index: int) -> int:
    """Kills its worker process on item 2 (a segfaulting decoder, say)."""
    if index == 2:
        os._exit(3)
    return 10 * index


def outcome_key(outcomes: list[ItemOutcome]) -> list[tuple[int, str, bytes | None, str | None]]:
    return [
        (o.index, o.label, None if o.value is None else o.value.tobytes(), o.error)
        for o in outcomes
    ]


ITEMS = list(range(7))
LABELS = [f"clip_{i}.mp4" for i in ITEMS]


def test_item_seed_equals_spawned_children() -> None:
    children = np.random.SeedSequence(SEED).spawn(10)
    for i in (0, 3, 9):
        np.testing.assert_array_equal(
            item_seed(SEED, i).generate_state(4), children[i].generate_state(4)
        )
    assert not np.array_equal(
        item_seed(SEED, 0).generate_state(4), item_seed(SEED + 1, 0).generate_state(4)
    )
    with pytest.raises(InvalidInput, match="index"):
        item_seed(SEED, -1)


def test_local_engine_in_order_with_failure_reported() -> None:
    calls: list[int] = []
    inline = map_items(draw, ITEMS, labels=LABELS, callback=lambda i, s: calls.append(i))
    assert [o.index for o in inline] == ITEMS and [o.label for o in inline] == LABELS
    assert sorted(calls) == ITEMS
    bad = inline[BAD]
    assert not bad.ok and bad.value is None
    assert bad.error == "InvalidInput: item 3 is corrupt (second line)"
    assert all(o.ok for o in inline if o.index != BAD)
    np.testing.assert_array_equal(
        inline[5].value,
        np.random.default_rng(np.random.SeedSequence(SEED).spawn(6)[5]).standard_normal(4),
    )
    summary = format_failures(inline)
    assert summary.splitlines() == [
        "1 of 7 items failed:",
        "  clip_3.mp4: InvalidInput: item 3 is corrupt (second line)",
    ]
    pooled = map_items(draw, ITEMS, labels=LABELS, workers=2)
    assert outcome_key(pooled) == outcome_key(inline)
    assert format_failures(inline[:BAD]) == ""


def test_local_pool_survives_a_dying_worker() -> None:
    out = map_items(die_on_two, list(range(5)), labels=[str(i) for i in range(5)], workers=2)
    assert [o.value for o in out] == [0, 10, None, 30, 40]
    assert out[2].error is not None and out[2].error.startswith("WorkerDied")
    assert [o.ok for o in out] == [True, True, False, True, True]


def test_bad_arguments() -> None:
    with pytest.raises(InvalidInput, match=r"engine must be one of \('local', 'ray'\)"):
        map_items(draw, ITEMS, labels=LABELS, engine="dask")
    with pytest.raises(InvalidInput, match="workers must be an integer >= 1"):
        map_items(draw, ITEMS, labels=LABELS, workers=0)
    with pytest.raises(InvalidInput, match="one entry per item"):
        map_items(draw, ITEMS, labels=LABELS[:-1])
    assert map_items(draw, [], labels=[]) == []


def nap_then_mark(item: tuple[int, str]) -> int:
    """Item 0 returns at once; the others sleep, then leave a mark (if not stopped)."""
    import time

    index, folder = item
    if index:
        time.sleep(30)
        (Path(folder) / f"done_{index}").write_text("finished")
    return index


def test_ctrl_c_in_the_parent_stops_the_pool_workers(tmp_path: Path) -> None:
    """KeyboardInterrupt while items run: raised at once, the running items never finish."""

    def interrupt(i: int, _value: float) -> None:
        raise KeyboardInterrupt  # Ctrl-C lands while the other workers still run

    items = [(i, str(tmp_path)) for i in range(3)]
    with pytest.raises(KeyboardInterrupt):
        map_items(nap_then_mark, items, labels=["a", "b", "c"], workers=3, callback=interrupt)
    assert not list(tmp_path.glob("done_*"))  # the sleepers were stopped, not waited for


def _closed_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])  # closed again when the block ends


@pytest.mark.parametrize("form", ["{}", "ray://{}"])
def test_an_unreachable_cluster_is_one_line_before_ray_starts(form: str, monkeypatch) -> None:
    """A closed port is refused by our probe, never handed to Ray (which waits minutes)."""
    ray = pytest.importorskip("ray", reason="ray is not installed")

    def no_init(**kwargs):
        raise AssertionError("ray.init must not be reached")

    monkeypatch.setattr(ray, "init", no_init)
    address = form.format(f"127.0.0.1:{_closed_port()}")
    with pytest.raises(InvalidInput, match=r"cannot reach the cluster at address .*refused"):
        map_items(draw, [0, 1], labels=["a", "b"], engine="ray", address=address)


# --------------------------------------------------------------------------- Ray


@pytest.fixture(scope="module")
def ray_cluster(tmp_path_factory: pytest.TempPathFactory):
    """A local 2-CPU Ray cluster for this module (session files under pytest's tmp)."""
    ray = pytest.importorskip("ray", reason="ray is not installed")
    # AF_UNIX socket paths are limited to 107 bytes: keep the session folder short
    temp = tmp_path_factory.mktemp("ray")
    try:
        ray.init(num_cpus=2, include_dashboard=False, _temp_dir=str(temp),
                 logging_level="WARNING", log_to_driver=False)  # fmt: skip
    except Exception as exc:  # any reason Ray cannot start here is a skip, with the reason
        pytest.skip(f"cannot start a local Ray cluster: {exc}")
    # Ray's workers cannot import this test module by name: ship its functions by value
    ray.cloudpickle.register_pickle_by_value(sys.modules[__name__])
    yield ray
    ray.cloudpickle.unregister_pickle_by_value(sys.modules[__name__])
    ray.shutdown()


@pytest.mark.slow
def test_ray_engine_equals_local(ray_cluster) -> None:
    local = map_items(draw, ITEMS, labels=LABELS)
    on_ray = map_items(draw, ITEMS, labels=LABELS, engine="ray", workers=2)
    assert outcome_key(on_ray) == outcome_key(local)
    assert on_ray[BAD].error == "InvalidInput: item 3 is corrupt (second line)"
    assert ray_cluster.is_initialized()  # a connection the engine did not open stays open


@pytest.mark.slow
def test_payload_monte_carlo_same_numbers_on_every_engine(ray_cluster) -> None:
    """1 process, 2 processes and Ray (2 CPUs) give bit-identical trials."""
    import dataclasses

    from dexlfd.experiments.payload import PayloadConfig
    from dexlfd.experiments.payload_montecarlo import MonteCarloConfig, run_payload_monte_carlo
    from dexlfd.plan.moves import lift_plan

    plan = lift_plan(1.0, z_high=0.3, y_start=-0.05, y_end=0.05)
    base = PayloadConfig(controllers=("ntsm-pd-dob",), plan=plan, obstacles=(), clearance=0.02)
    cfg = MonteCarloConfig(trials=3, base=base, seed=5)
    results = [
        run_payload_monte_carlo(
            dataclasses.replace(cfg, base=dataclasses.replace(base, engine=e, workers=w))
        )
        for e, w in (("local", 1), ("local", 2), ("ray", 2))
    ]
    first = results[0]
    assert len(first.trials) == 3 and not first.failures
    assert len({t.draw.payload_kg for t in first.trials}) == 3  # the trials differ
    for other in results[1:]:
        assert other.trials == first.trials  # dataclass equality: every float bit-identical
        assert other.summary == first.summary


@pytest.mark.slow
def test_ray_chunks_many_items_and_keeps_each_outcome(ray_cluster) -> None:
    """40 items go to Ray in chunks of several; outcomes and failures stay per item."""
    items = list(range(40))
    labels = [f"item {i}" for i in items]
    local = map_items(draw, items, labels=labels)
    on_ray = map_items(draw, items, labels=labels, engine="ray", workers=2)
    assert outcome_key(on_ray) == outcome_key(local)
    assert [o.ok for o in on_ray] == [i != BAD for i in items]


@pytest.mark.slow
def test_ray_worker_death_fails_only_its_item(ray_cluster) -> None:
    """A chunk whose worker dies is rerun item by item: only the killer is reported."""
    n = 24  # chunks of 3 on 2 CPUs: item 2 takes items 0 and 1 down with it
    out = map_items(die_on_two, list(range(n)), labels=[str(i) for i in range(n)],
                    engine="ray", workers=2)  # fmt: skip
    assert [o.value for o in out] == [None if i == 2 else 10 * i for i in range(n)]
    assert [o.ok for o in out] == [i != 2 for i in range(n)]


POOLS_SCRIPT = """
import multiprocessing
from dexlfd.engine import map_items

def child():
    print("child", [o.value for o in map_items(abs, [-4, 5], labels=["c", "d"], workers=2)])

if __name__ == "__main__":
    proc = multiprocessing.get_context("fork").Process(target=child)
    proc.start()
    proc.join()
    for _ in range(2):  # the second pool reuses the fork server
        print("main", [o.value for o in map_items(abs, [-1, 2], labels=["a", "b"], workers=2)])
"""


def test_a_command_with_process_pools_leaves_no_process_behind(
    tmp_path: Path, session_processes
) -> None:
    """The fork servers and resource trackers of the pools (in the main process and in a
    forked child) are stopped before their process exits: once the command has ended,
    nothing of its session is left, not even an unreaped zombie."""
    import subprocess

    script = tmp_path / "pools.py"
    script.write_text(POOLS_SCRIPT)
    src = str(Path(__file__).resolve().parents[1] / "src")
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join(filter(None, [src, os.environ.get("PYTHONPATH")])),
    }
    with (tmp_path / "out.txt").open("w") as out:  # a file: no pipe held open by a helper
        proc = subprocess.Popen([sys.executable, str(script)], stdout=out, stderr=subprocess.STDOUT,
                                env=env, start_new_session=True)  # fmt: skip
        assert proc.wait(timeout=600) == 0, (tmp_path / "out.txt").read_text()
    left = session_processes(proc.pid)
    assert not left, left
    lines = (tmp_path / "out.txt").read_text().splitlines()
    assert lines == ["child [4, 5]", "main [1, 2]", "main [1, 2]"]
