"""The demo's HTML report: every stage's figures, tables and settings, prose from a template.

The sentences live in ``templates/demo_report.ini`` (shipped as package data): one
section per stage, each value a :class:`string.Template` filled from the stage's
summary. This module picks the figures, tables and values; it holds no prose.
"""

from __future__ import annotations

import configparser
import dataclasses
import functools
import os
from importlib import resources
from pathlib import Path
from string import Template
from typing import TYPE_CHECKING, Any

from dexlfd import __version__

if TYPE_CHECKING:
    from dexlfd.apps.demo import DemoConfig
    from dexlfd.viz.report import Section

__all__ = ["build_demo_report", "jsonable", "prose", "section"]

Results = dict[str, dict[str, Any]]

CONTROL_HEADER = ["controller", "payload [kg]", "E_NOB [mm]", "E_OB [mm]", "ΔE [mm]",
                  "Δ_OB [%]", "max orientation error [deg]", "stopped"]  # fmt: skip
PLACED_HEADER = ["controller", "payload [kg]", "object final position [m]",
                 "error from the place point [mm]", "tilt [deg]", "impact speed [m/s]",
                 "speed at release [m/s]"]  # fmt: skip


class _Values(dict[str, Any]):
    """Template values as words (:func:`dexlfd.viz.report.words`); a missing one reads "none"."""

    def __getitem__(self, key: str) -> str:
        from dexlfd.viz.report import words

        return words(super().__getitem__(key)) if key in self else "none"


@functools.cache
def _templates(name: str = "demo_report") -> configparser.ConfigParser:
    """The packaged prose ``templates/<name>.ini`` (one per report: demo, teach)."""
    parser = configparser.ConfigParser(interpolation=None)
    text = resources.files("dexlfd.apps").joinpath(f"templates/{name}.ini").read_text("utf-8")
    parser.read_string(text)
    return parser


def prose(
    section: str, key: str, values: dict[str, Any] | None = None, *, template: str = "demo_report"
) -> str:
    """The template ``[section] key`` of ``templates/<template>.ini``, ``$names`` filled."""
    text = " ".join(_templates(template)[section][key].split())
    return Template(text).substitute(_Values(values or {}))


def _paragraphs(
    section: str, values: dict[str, Any], prefix: str = "p", template: str = "demo_report"
) -> list[str]:
    keys = sorted(k for k in _templates(template)[section] if k[len(prefix) :].isdigit()
                  and k.startswith(prefix))  # fmt: skip
    return [prose(section, k, values, template=template) for k in keys]


def _figures(results: Results, stage: str) -> list[tuple[Path, str]]:
    outs = results.get(stage, {}).get("outputs", {})
    return [(Path(p), Path(p).stem.replace("_", " ")) for k, p in outs.items()
            if k.startswith("fig")]  # fmt: skip


def _summary(results: Results, stage: str) -> dict[str, Any]:
    return dict(results.get(stage, {}).get("summary", {}))


def section(
    name: str, values: dict[str, Any], template: str = "demo_report", **parts: Any
) -> Section:
    """The report section ``[name]`` of ``template``: title, paragraphs, notes and ``parts``."""
    from dexlfd.viz.report import Section

    return Section(
        prose(name, "title", values, template=template),
        paragraphs=_paragraphs(name, values, template=template),
        notes=_paragraphs(name, values, "note", template=template),
        **parts,
    )


def _capture_section(results: Results) -> Section:
    from dexlfd.viz.report import Section

    s = _summary(results, "capture")
    if "skipped" in s:
        return Section(prose("capture", "title"), notes=[s["skipped"]])
    s["detection_pct"] = f"{100 * s.get('detection_rate', 0):.1f}"
    outs = results.get("capture", {}).get("outputs", {})
    videos = [(Path(outs["overlay"]), prose("capture", "overlay"))] if "overlay" in outs else []
    return section("capture", s, figures=_figures(results, "capture"), videos=videos)


def _plan_values(s: dict[str, Any], cfg: DemoConfig) -> dict[str, Any]:
    s["executed_height"] = cfg.executed_height
    s["limits_exceeded"] = s.get("limits_exceeded") or "none"
    s["variance_pair"] = "; ".join(prose("plan", "pair_item", v)
                                   for v in s.get("variance_pair", []))  # fmt: skip
    place = s.get("place")
    s["place"] = prose("plan", "place_none") if not place else prose("plan", "place", {
        "lowered_mm": f"{-1e3 * place['height_change']:.1f}",
        "surface_z": place["surface_z"],
        "release_t": f"{place['release_t']:.2f}",
    })  # fmt: skip
    return s


def _control_section(results: Results, cfg: DemoConfig) -> Section:
    s = _summary(results, "control")
    s["payload_kg"] = cfg.payload_kg
    rows = [[r["controller"], r["payload_kg"], r["e_nob_mm"], r["e_ob_mm"], r["delta_e_mm"],
             r["delta_ob_pct"], r["max_orientation_error_deg"], r["stopped"] or ""]
            for r in s.get("rows", [])]  # fmt: skip
    placed = [[p["controller"], p["payload_kg"], p["final_position_m"], p["position_error_mm"],
               p["tilt_deg"], p["impact_speed_m_s"], p["release_speed_m_s"]]
              for p in s.get("placed", [])]  # fmt: skip
    control = section(
        "control", s,
        tables=[(CONTROL_HEADER, rows, prose("control", "errors_caption")),
                (PLACED_HEADER, placed, prose("control", "placed_caption"))],
        figures=_figures(results, "control") + _figures(results, "control_figures"),
    )  # fmt: skip
    table_path = results.get("control", {}).get("outputs", {}).get("table")
    if table_path is not None and Path(table_path).is_file():
        control.preformatted.append(Path(table_path).read_text())
    return control


def _files_section(results: Results, cfg: DemoConfig, out: Path) -> Section:
    exports = results.get("export", {}).get("outputs", {})
    values = {"exports": ", ".join(os.path.relpath(p, out) for p in exports.values())}
    times = [[k, round(v.get("seconds", 0.0), 2), v.get("reused", False)]
             for k, v in results.items()]  # fmt: skip
    return section(
        "files", values,
        tables=[(["stage", "seconds", "reused"], times, prose("files", "times_caption"))],
        settings=jsonable(dataclasses.asdict(cfg)),
    )  # fmt: skip


def build_demo_report(cfg: DemoConfig, out: Path, results: Results) -> Path:
    """Write ``out/report.html`` from the stages' ``results``; returns its path."""
    from dexlfd.viz.report import Report, write_report

    learn = _summary(results, "learn")
    learn["outliers"] = learn.get("outliers") or "none"
    video = results.get("video", {}).get("outputs", {}).get("video")
    caption = {"controller": cfg.video_controller, "payload_kg": cfg.payload_kg}
    sections = [
        section("demos", _summary(results, "demos"), figures=_figures(results, "demos")),
        _capture_section(results),
        section("learn", learn, figures=_figures(results, "learn"),
                 settings=dataclasses.asdict(cfg.learn)),
        section("plan", _plan_values(_summary(results, "plan"), cfg),
                 figures=_figures(results, "plan")),
        _control_section(results, cfg),
        section("video", {}, videos=[(Path(video), prose("video", "caption", caption))]
                 if video else []),
        _files_section(results, cfg, out),
    ]  # fmt: skip
    report = Report(
        title=prose("report", "title"),
        intro=prose("report", "intro", {"version": __version__, "seed": cfg.seed}),
        sections=sections,
    )
    return write_report(report, out / "report.html")


def jsonable(obj: Any) -> Any:
    """``obj`` with tuples as lists and paths as strings (for JSON)."""
    if isinstance(obj, dict):
        return {k: jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [jsonable(v) for v in obj]
    if isinstance(obj, Path):
        return str(obj)
    return obj
