"""Reading a version-1 demonstration file: its typed facts were entries of ``meta``."""

from __future__ import annotations

from typing import Any

__all__ = ["facts_from_v1_meta"]

# meta entries of version 1 that are typed facts of version 2, under the same name
_SAME_NAME = ("frame", "source_frames", "phases", "episode", "trim", "recording", "quality")
_APPLIED_FRAME = ("camera_to_base", "scale", "from_frame", "method")


def facts_from_v1_meta(meta: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """``(facts, meta)``: the facts' JSON values and the provenance that stays in ``meta``.

    A ``null`` entry stood for "absent" and lifts nothing. ``meta["task_frame"]`` held
    the transform and the estimate's provenance together: the transform becomes the
    ``task_frame`` fact, the rest stays in ``meta["task_frame"]``.
    """
    rest = dict(meta)
    facts: dict[str, Any] = {}
    for key in _SAME_NAME:
        value = rest.pop(key, None)
        if value is not None:
            facts[key] = value
    applied = rest.pop("task_frame", None)
    if isinstance(applied, dict):
        facts["task_frame"] = {k: applied[k] for k in _APPLIED_FRAME if k in applied}
        provenance = {k: v for k, v in applied.items() if k not in _APPLIED_FRAME}
        if provenance:
            rest["task_frame"] = provenance
    elif applied is not None:
        facts["task_frame"] = applied  # refused on load, naming the entry
    return facts, rest
