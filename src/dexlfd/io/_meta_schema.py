"""The JSON types of the ``meta`` entries that dexlfd reads back, per file kind.

A file's ``meta`` is free-form JSON, but some of its top-level entries are read
back (a plan's ``settings``, a rollout's ``plant``, a demonstration's ``capture``): an
entry of the wrong type there (``"capture": "x"``) would fail deep inside a stage.
:func:`check_meta_types` refuses such a file when it is loaded, in one line naming
the file and the entry. Entries not listed are kept as they are; ``null``
stands for "absent" wherever a table or list is expected, as the writers use it.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from dexlfd.errors import InvalidFile

__all__ = ["META_TYPES", "check_meta_types"]

_TABLE, _LIST, _TEXT, _NUMBER, _FLAG = "object", "list", "string", "number", "boolean"

# kind -> top-level entry -> JSON type: the entries a later stage reads into (its
# tables and lists), with the type every writer gives them
META_TYPES: dict[str, dict[str, str]] = {
    "demonstration": {
        "source": _TEXT, "capture": _TABLE, "grasp": _TABLE, "motion": _TABLE,
    },
    # a model's, plan's and rollout's facts are typed fields (dexlfd.io._facts): their
    # meta keeps provenance only
    "model": {"source": _TEXT, "settings": _TABLE},
    "plan": {"settings": _TABLE},
    "rollout": {"plan_meta": _TABLE, "plant": _TABLE},
}  # fmt: skip


def _is(value: Any, json_type: str) -> bool:
    if json_type == _TABLE:
        return value is None or isinstance(value, dict)
    if json_type == _LIST:
        return value is None or isinstance(value, list)
    if json_type == _TEXT:
        return isinstance(value, str)
    if json_type == _NUMBER:
        return isinstance(value, int | float) and not isinstance(value, bool)
    return isinstance(value, bool)


def check_meta_types(meta: Mapping[str, Any], kind: str, where: str) -> None:
    """Refuse ``meta`` whose listed entries of ``kind`` have another JSON type.

    Raises
    ------
    InvalidFile
        Naming ``where`` (the file), the entry, the expected and the found type.
    """
    for key, json_type in META_TYPES.get(kind, {}).items():
        if key in meta and not _is(meta[key], json_type):
            found = type(meta[key]).__name__
            raise InvalidFile(
                f"{where}: meta entry {key!r} must be a JSON {json_type}, got {found} "
                f"({str(meta[key])[:40]!r})"
            )
