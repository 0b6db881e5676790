"""Reading a version-1 demonstration file: its typed facts were entries of ``meta``.

The same layout is the JSON that travels with a demonstration outside the ``.npz``
(a LeRobot dataset's ``dexlfd/meta``): :func:`facts_to_v1_meta` writes it,
:func:`facts_from_v1_meta` reads it back.
"""

from __future__ import annotations

from dataclasses import fields
from typing import Any

from dexlfd.io._facts import Fact, to_json
from dexlfd.io.demonstration_facts import AppliedFrame, Capture, Motion

__all__ = ["facts_from_v1_meta", "facts_to_v1_meta"]

# meta entries of version 1 that are typed facts of version 2, under the same name
_SAME_NAME = ("frame", "source_frames", "phases", "episode", "trim", "recording", "quality")
# meta tables of version 1 that held a fact's entries beside provenance
_SHARED: dict[str, type[Fact]] = {
    "task_frame": AppliedFrame,
    "capture": Capture,
    "motion": Motion,
}


def facts_from_v1_meta(meta: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """``(facts, meta)``: the facts' JSON values and the provenance that stays in ``meta``.

    A ``null`` entry stood for "absent" and lifts nothing. ``meta["task_frame"]``,
    ``meta["capture"]`` and ``meta["motion"]`` held a fact's entries beside
    provenance: the fact's entries are lifted, the rest stays in the table.
    """
    rest = dict(meta)
    facts: dict[str, Any] = {}
    for key in _SAME_NAME:
        value = rest.pop(key, None)
        if value is not None:
            facts[key] = value
    for key, fact in _SHARED.items():
        table = rest.pop(key, None)
        if not isinstance(table, dict):
            if table is not None:
                facts[key] = table  # refused on load, naming the entry
            continue
        names = {f.name for f in fields(fact)}
        lifted = {k: v for k, v in table.items() if k in names and v is not None}
        if lifted:
            facts[key] = lifted
        provenance = {k: v for k, v in table.items() if k not in names}
        if provenance:
            rest[key] = provenance
    return facts, rest


def facts_to_v1_meta(record: Any) -> dict[str, Any]:
    """``record.meta`` with its facts (``record.FACTS``) put back as version 1 held them."""
    meta = dict(record.meta)
    for key in record.FACTS:
        value = getattr(record, key)
        if value is None:
            continue
        if key in _SHARED:
            table = meta.get(key)
            meta[key] = {**(table if isinstance(table, dict) else {}), **to_json(value)}
        else:
            meta[key] = to_json(value)
    return meta
