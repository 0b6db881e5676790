"""Does the learned task generalise over the table? Pick here, place there, score it.

:func:`run_generalize` takes a learned model with grasp events and a grid of pick and
place positions over the Panda's reachable table area (:func:`table_grid`: picks on a
grid over one area, places on a grid over another, paired so that every pick meets a
different place and the carry distances and directions vary), and for every pair:

1. plans it (:func:`dexlfd.plan.plan_from_model` with ``pick``/``place``, then
   made feasible there by :func:`dexlfd.plan.feasibility.make_feasible`: the plan
   ``dexlfd plan`` writes);
2. simulates it with each controller at each payload (the object stands on the
   plan's pick support; the controllers' model is off by ``model_error``);
3. scores it (:func:`dexlfd.control.grasp.placement_report`: carried, within 2 cm of
   the place position, upright, set down slower than 0.1 m/s).

A payload of 0 kg is simulated with a 10 g box (an object without mass cannot be
simulated; it is as near to "no load" as a box that can still be carried and
placed): the rows say so. Planning and simulation run on the engine
(:func:`dexlfd.engine.map_items`, local processes or Ray); results do not depend on
it. A pair the planner refuses (out of reach, no IK) is a failed pair with its reason.
"""

from __future__ import annotations

import contextlib
import functools
import logging
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.control import LoopConfig, TrackingStopped, make_controller, track
from dexlfd.control.slip import carry_slip
from dexlfd.engine import ENGINES, map_items
from dexlfd.errors import InvalidInput
from dexlfd.io import LearnedModel, Plan
from dexlfd.robot import PlantConfig
from dexlfd.robot.plant import HALF_SIZES
from dexlfd.robot.robot_model import perturbed_model

__all__ = [
    "PLAN_CPU_S",
    "TASK_SIM_SPEED_X",
    "GeneralizeConfig",
    "check_areas",
    "GeneralizeResult",
    "format_generalize",
    "generalize_json",
    "run_generalize",
    "table_grid",
]

logger = logging.getLogger(__name__)

# what one pair costs, measured with one worker (dexlfd experiment generalize --workers 1,
# 1 vs 3 pairs of the six-demonstration model): planning ~1.8 s of CPU a pair; the
# simulation with the object's contacts ~4x real time (not the ~30x of the payload
# study's contact-free lift)
PLAN_CPU_S = 1.8  # [s]
TASK_SIM_SPEED_X = 4.0
NO_LOAD_KG = 0.01  # [kg] the box that stands for "0 kg" (a massless body cannot move)
MIN_AREA = (0.30, 0.40)  # [m] the smallest pick or place area (x by y) of the study


def table_grid(
    n_pairs: int,
    pick_area: tuple[tuple[float, float], tuple[float, float]],
    place_area: tuple[tuple[float, float], tuple[float, float]],
) -> list[tuple[tuple[float, float], tuple[float, float]]]:
    """``n_pairs`` (pick xy, place xy) [m] over the two areas ``((x0, x1), (y0, y1))``.

    Picks fill an ``r x c`` grid over the pick area (``r * c >= n_pairs``, as square as
    the area), places the same grid over the place area; pair ``i`` takes pick ``i``
    and place ``(i * s) mod N`` with ``s`` coprime to ``N`` (so each place is used once
    and neighbouring picks go to distant places).
    """
    if n_pairs < 1:
        raise InvalidInput(f"n_pairs must be >= 1, got {n_pairs}")
    for name, ((x0, x1), (y0, y1)) in (("pick_area", pick_area), ("place_area", place_area)):
        if not (x1 > x0 and y1 > y0):
            raise InvalidInput(f"{name} must be (x0 < x1, y0 < y1) [m], got {pick_area}")
    cols = int(np.ceil(np.sqrt(n_pairs)))
    rows = int(np.ceil(n_pairs / cols))

    def grid(area: tuple[tuple[float, float], tuple[float, float]]) -> FloatArray:
        (x0, x1), (y0, y1) = area
        xs = np.linspace(x0, x1, rows) if rows > 1 else np.array([(x0 + x1) / 2])
        ys = np.linspace(y0, y1, cols) if cols > 1 else np.array([(y0 + y1) / 2])
        return np.array([(x, y) for x in xs for y in ys])[:n_pairs]

    picks, places = grid(pick_area), grid(place_area)
    n = picks.shape[0]
    step = next(s for s in (7, 11, 13, 17, 19, 23, 29, 31, 1) if np.gcd(s, n) == 1 or s == 1)
    return [
        ((float(picks[i, 0]), float(picks[i, 1])),
         (float(places[(i * step) % n, 0]), float(places[(i * step) % n, 1])))
        for i in range(n)
    ]  # fmt: skip


@dataclass(frozen=True)
class GeneralizeConfig:
    """Settings of the generalisation study.

    Attributes
    ----------
    n_pairs : int
        Pick-place pairs (>= 1; the study's claim needs >= 25).
    pick_area, place_area : ((x0, x1), (y0, y1))
        Table areas [m] in the base frame (default 30 x 40 cm each, right and left of
        the base in front of it, their far corners 0.80 m from the shoulder: nearer
        the 0.855 m reach the stretched elbow is near its singularity).
    pick_z, place_z : float, optional
        TCP height at the pick and place [m]; default: the demonstrated ones.
    controllers : tuple of str
    payloads : tuple of float
        Object masses [kg]; 0 is simulated as a 10 g box (:data:`NO_LOAD_KG`).
    model_error : float
        Relative mass/inertia error of the controllers' model.
    obstacles : tuple
        Obstacles every plan avoids (:mod:`dexlfd.geometry`).
    seed, workers, engine, ray_address
        As in the payload study (:class:`~dexlfd.experiments.payload.PayloadConfig`).
    hand : {"franka", "softhand"}
        The end-effector (:class:`~dexlfd.robot.PlantConfig`).
    shape : {"box", "cylinder", "sphere"}
        The object, of its default size (:data:`dexlfd.robot.plant.HALF_SIZES`).
    stop_force : float
        The softhand's grasp force [N].
    """

    n_pairs: int = 25
    pick_area: tuple[tuple[float, float], tuple[float, float]] = ((0.32, 0.62), (-0.45, -0.05))
    place_area: tuple[tuple[float, float], tuple[float, float]] = ((0.32, 0.62), (0.05, 0.45))
    pick_z: float | None = None
    place_z: float | None = None
    controllers: tuple[str, ...] = ("ntsm-pd",)
    payloads: tuple[float, ...] = (0.0, 1.2)
    model_error: float = 0.1
    obstacles: tuple[Any, ...] = ()
    seed: int = 0
    workers: int = 1
    engine: str = "local"
    ray_address: str | None = None
    hand: str = "franka"
    shape: str = "box"
    stop_force: float = 3.0

    def __post_init__(self) -> None:
        self.plant(1.0)  # the hand, the shape, and whether the hand can hold it
        if not (isinstance(self.n_pairs, int) and self.n_pairs >= 1):
            raise InvalidInput(f"n_pairs must be an integer >= 1, got {self.n_pairs!r}")
        if not self.controllers:
            raise InvalidInput("controllers must not be empty")
        for name in self.controllers:
            make_controller(name)
        if not self.payloads or any(not (0.0 <= m <= 3.0) for m in self.payloads):
            raise InvalidInput(f"payloads must be masses in [0, 3] kg, got {self.payloads}")
        if self.engine not in ENGINES:
            raise InvalidInput(f"engine must be one of {ENGINES}, got {self.engine!r}")
        if self.workers < 1:
            raise InvalidInput(f"workers must be >= 1, got {self.workers}")

    def plant(self, payload: float, obstacles: tuple[Any, ...] = ()) -> PlantConfig:
        """The plant of one run with ``payload`` [kg] (0: a :data:`NO_LOAD_KG` object)."""
        return PlantConfig(
            payload_kg=max(payload, NO_LOAD_KG), obstacles=obstacles, hand=self.hand,
            payload_shape=self.shape, payload_half_size=HALF_SIZES[self.shape],
            stop_force=self.stop_force,
        )  # fmt: skip

    def pairs(self, model: LearnedModel) -> list[tuple[FloatArray, FloatArray]]:
        """The (pick, place) TCP positions [m] of the study, heights filled in."""
        assert model.event_position is not None
        zp = float(model.event_position[0, 2]) if self.pick_z is None else self.pick_z
        zq = float(model.event_position[1, 2]) if self.place_z is None else self.place_z
        return [
            (np.array([*a, zp]), np.array([*b, zq]))
            for a, b in table_grid(self.n_pairs, self.pick_area, self.place_area)
        ]


@dataclass
class GeneralizeResult:
    """Per pair: the plan's facts; per (pair, controller, payload): the placement."""

    config: GeneralizeConfig
    pairs: list[tuple[FloatArray, FloatArray]]
    plans: list[dict[str, Any]]  # per pair: ok, error, event errors, time scaling
    runs: list[dict[str, Any]]  # per run: pair, controller, payload_kg, placement, error
    notes: list[str] = field(default_factory=list)

    def summary(self) -> list[dict[str, Any]]:
        """One row per (controller, payload): success rate and placement error."""
        rows = []
        for ctrl in self.config.controllers:
            for m in self.config.payloads:
                runs = [r for r in self.runs if r["controller"] == ctrl and r["payload_kg"] == m]
                ok = [r for r in runs if r.get("placement", {}).get("success")]
                carried = [r for r in runs if r.get("placement", {}).get("carried")]
                err = [
                    r["placement"]["place_error_m"] for r in runs
                    if r.get("placement", {}).get("place_error_m") is not None
                ]  # fmt: skip
                speed = [
                    r["placement"]["set_down_speed"] for r in runs
                    if r.get("placement", {}).get("set_down_speed") is not None
                ]  # fmt: skip
                slip = [r["slip_m"] for r in runs if r.get("slip_m") is not None]
                rows.append({
                    "controller": ctrl, "payload_kg": m, "pairs": len(runs),
                    "slip_median_m": float(np.median(slip)) if slip else None,
                    "slip_worst_m": float(np.max(slip)) if slip else None,
                    "success_rate": len(ok) / max(len(runs), 1),
                    "carried_rate": len(carried) / max(len(runs), 1),
                    "place_error_median_m": float(np.median(err)) if err else None,
                    "place_error_worst_m": float(np.max(err)) if err else None,
                    "set_down_speed_max_m_s": float(np.max(speed)) if speed else None,
                })  # fmt: skip
        return rows


def _plan_pair(
    model: LearnedModel, obstacles: tuple[Any, ...], pair: tuple[FloatArray, FloatArray]
) -> Plan:
    """Plan one pair as ``dexlfd plan --pick --place`` does (time-scaled, feasible)."""
    from dexlfd.plan import PlanConfig, plan_from_model

    pick, place = pair
    cfg = PlanConfig(
        pick=tuple(pick), place=tuple(place), obstacles=obstacles, on_limit="scale"
    )  # fmt: skip
    with _time_scaling_at_debug():  # one summary line per study instead (run_generalize)
        return plan_from_model(model, cfg)  # feasible: plan_from_model slows it where needed


class _AtDebug(logging.Filter):
    """A planner's per-plan time-scaling warning as a DEBUG line (shown only with -vv)."""

    def filter(self, record: logging.LogRecord) -> bool:
        if record.levelno != logging.WARNING or not str(record.msg).startswith("time scaling"):
            return True
        record.levelno, record.levelname = logging.DEBUG, "DEBUG"
        return logging.getLogger("dexlfd").isEnabledFor(logging.DEBUG)


@contextlib.contextmanager
def _time_scaling_at_debug() -> Iterator[None]:
    """Demote ``dexlfd.plan.pipeline``'s time-scaling warning to DEBUG meanwhile."""
    planner = logging.getLogger("dexlfd.plan.pipeline")
    at_debug = _AtDebug()
    planner.addFilter(at_debug)
    try:
        yield
    finally:
        planner.removeFilter(at_debug)


def _say_time_scaling(plans: list[dict[str, Any]]) -> None:
    """One warning for the study: how many pairs were slowed, and the worst."""
    slowed = [(p["time_scaling_largest"], i) for i, p in enumerate(plans)
              if p["ok"] and p["time_scaling_needed"]]  # fmt: skip
    if slowed:
        worst, i = max(slowed)
        logger.warning(
            "time scaling: %d of %d planned pair(s) slowed (the robot's limits, the "
            "demonstrated speed), at most %.2fx (pair %d); each pair's slow-downs with -vv",
            len(slowed), sum(p["ok"] for p in plans), worst, i,
        )  # fmt: skip


def _simulate(cfg: GeneralizeConfig, job: tuple[Plan, str, float]) -> dict[str, Any]:
    """One run: the placement report (or the safety stop's reason)."""
    from dexlfd.control.grasp import placement_report
    from dexlfd.robot import plan_world

    plan, ctrl, payload = job
    model = perturbed_model(cfg.model_error, np.random.default_rng([cfg.seed, 1]))
    plant = cfg.plant(payload, plan_world(plan))
    try:
        ro = track(plan, make_controller(ctrl), model, plant, LoopConfig(),
                   rng=np.random.default_rng([cfg.seed, 2]))  # fmt: skip
    except TrackingStopped as exc:
        return {"stopped": str(exc), "placement": {"success": False, "carried": False,
                                                   "failure": f"safety stop: {exc}"}}  # fmt: skip
    err = np.linalg.norm(ro.ee_position - ro.ref_position, axis=1)
    placement = (ro.placement or placement_report(ro)).to_dict()
    k = int(np.argmax(ro.grasp)) if ro.grasp is not None and ro.grasp.any() else 0
    return {
        "placement": placement,
        "slip_m": carry_slip(ro),
        "tracking_max_m": float(err.max()),
        "tcp_error_at_grasp_m": float(err[k]),
    }


def run_generalize(
    model: LearnedModel,
    cfg: GeneralizeConfig,
    *,
    quiet: bool = True,
    callback: Callable[[int, float], None] | None = None,
) -> GeneralizeResult:
    """Plan, simulate and score every pair (module docstring).

    Raises
    ------
    InvalidInput
        The model has no grasp events (nothing to pick or place).
    """
    if not isinstance(model, LearnedModel) or not model.has_events:
        raise InvalidInput(
            "model has no grasp events: learn it from demonstrations with a grasp "
            "(their 'grasp' channel) to generalise pick and place"
        )
    pairs = cfg.pairs(model)
    labels = [f"pair {i}: pick {np.round(a, 3).tolist()} place {np.round(b, 3).tolist()}"
              for i, (a, b) in enumerate(pairs)]  # fmt: skip
    planned = map_items(
        functools.partial(_plan_pair, model, tuple(cfg.obstacles)), pairs, labels=labels,
        engine=cfg.engine, workers=cfg.workers, address=cfg.ray_address,
        desc="generalize: plan", quiet=quiet,
    )  # fmt: skip
    plans: list[dict[str, Any]] = []
    jobs: list[tuple[Plan, str, float]] = []
    index: list[tuple[int, str, float]] = []
    for i, out in enumerate(planned):
        if not out.ok:
            plans.append({"ok": False, "error": out.error})
            continue
        plan: Plan = out.value
        # every slow-down: the parts' Cartesian ones and the joint-space ones
        feas = plan.time_scaling or plan.feasibility
        plans.append({
            "ok": True, "duration_s": float(plan.t[-1]),
            "event_errors": None if plan.event_errors is None else plan.event_errors.to_json(),
            "time_scaling_needed": bool(feas is not None and feas.needed),
            "time_scaling_largest": float(1.0 if feas is None else feas.largest or 1.0),
        })  # fmt: skip
        for ctrl in cfg.controllers:
            for m in cfg.payloads:
                jobs.append((plan, ctrl, m))
                index.append((i, ctrl, m))
    _say_time_scaling(plans)
    simulated = map_items(
        functools.partial(_simulate, cfg), jobs,
        labels=[f"{labels[i]} {c} {m:g} kg" for i, c, m in index],
        engine=cfg.engine, workers=cfg.workers, address=cfg.ray_address,
        desc="generalize: simulate", quiet=quiet, callback=callback,
    )  # fmt: skip
    runs: list[dict[str, Any]] = []
    for (i, ctrl, m), out in zip(index, simulated, strict=True):
        row: dict[str, Any] = {"pair": i, "controller": ctrl, "payload_kg": m}
        if out.ok:
            row.update(out.value)
        else:
            row["placement"] = {"success": False, "carried": False, "failure": out.error}
        runs.append(row)
    for i, p in enumerate(plans):  # a refused plan fails every run of its pair
        if not p["ok"]:
            for ctrl in cfg.controllers:
                for m in cfg.payloads:
                    failure = f"not planned: {p['error']}"
                    runs.append({"pair": i, "controller": ctrl, "payload_kg": m,
                                 "placement": {"success": False, "carried": False,
                                               "failure": failure}})  # fmt: skip
    notes = [f"0 kg is simulated as a {1e3 * NO_LOAD_KG:g} g box"] if 0.0 in cfg.payloads else []
    return GeneralizeResult(cfg, pairs, plans, runs, notes)


def format_generalize(result: GeneralizeResult) -> str:
    """The summary table and the planning figures as text."""
    lines = [
        f"{'controller':<12} {'payload':>8} {'pairs':>5} {'placed':>7} {'carried':>8} "
        f"{'err median':>11} {'err worst':>10} {'set-down max':>13} {'slip max':>9}"
    ]
    for r in result.summary():

        def mm(v: float | None) -> str:
            return "-" if v is None else f"{1e3 * v:.1f} mm"

        speed = r["set_down_speed_max_m_s"]
        lines.append(
            f"{r['controller']:<12} {r['payload_kg']:>6g} kg {r['pairs']:>5} "
            f"{100 * r['success_rate']:>6.0f}% {100 * r['carried_rate']:>7.0f}% "
            f"{mm(r['place_error_median_m']):>11} {mm(r['place_error_worst_m']):>10} "
            f"{'-' if speed is None else f'{speed:.3f} m/s':>13} {mm(r['slip_worst_m']):>9}"
        )
    ok = [p for p in result.plans if p["ok"]]
    if ok:
        pick = [p["event_errors"]["pick_position_error_m"] for p in ok]
        ang = [p["event_errors"]["pick_angle_error_deg"] for p in ok]
        place = [p["event_errors"]["place_position_error_m"] for p in ok]
        scaled = [p["time_scaling_largest"] for p in ok if p["time_scaling_needed"]]
        lines.append(
            f"plans: {len(ok)} of {len(result.plans)} planned; pose error at the events "
            f"(plan): pick <= {1e3 * max(pick):.2f} mm / {max(ang):.2f} deg, place <= "
            f"{1e3 * max(place):.2f} mm; time scaling needed in {len(scaled)} "
            f"(largest {max(scaled, default=1.0):.2f}x)"
        )
    for i, p in enumerate(result.plans):
        if not p["ok"]:
            lines.append(f"pair {i} not planned: {p['error']}")
    failures = [r for r in result.runs if not r["placement"].get("success")]
    for r in failures[:10]:
        lines.append(
            f"pair {r['pair']} {r['controller']} {r['payload_kg']:g} kg: "
            f"{r['placement'].get('failure')}"
        )
    if len(failures) > 10:
        lines.append(f"... and {len(failures) - 10} more failed runs (see the JSON)")
    lines += [f"note: {n}" for n in result.notes]
    return "\n".join(lines)


def generalize_json(result: GeneralizeResult) -> dict[str, Any]:
    """Everything as JSON-able data."""
    cfg = result.config
    return {
        "config": {
            "n_pairs": cfg.n_pairs, "pick_area_m": cfg.pick_area, "place_area_m": cfg.place_area,
            "controllers": list(cfg.controllers), "payloads_kg": list(cfg.payloads),
            "model_error": cfg.model_error, "seed": cfg.seed, "engine": cfg.engine,
            "hand": cfg.hand, "shape": cfg.shape,
        },
        "pairs": [{"pick": a.tolist(), "place": b.tolist()} for a, b in result.pairs],
        "plans": result.plans,
        "runs": result.runs,
        "summary": result.summary(),
        "notes": result.notes,
    }  # fmt: skip


def check_areas(areas: Sequence[tuple[tuple[float, float], tuple[float, float]]]) -> list[str]:
    """Which areas are smaller than :data:`MIN_AREA` (messages; empty when none)."""
    out = []
    for (x0, x1), (y0, y1) in areas:
        if x1 - x0 < MIN_AREA[0] - 1e-9 or y1 - y0 < MIN_AREA[1] - 1e-9:
            out.append(
                f"area x {x0:g}..{x1:g}, y {y0:g}..{y1:g} m is smaller than "
                f"{MIN_AREA[0]:g} x {MIN_AREA[1]:g} m"
            )
    return out
