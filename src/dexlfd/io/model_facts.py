"""The typed facts of a learned-model file: what learning found and planning reads."""

from __future__ import annotations

from dataclasses import dataclass, field

from dexlfd.io._facts import Fact

__all__ = ["DemonstrationEvents", "GraspEventsFound"]


@dataclass(frozen=True)
class DemonstrationEvents(Fact):
    """One demonstration's grasp and release: on its own clock and on the model's [s].

    ``skipped`` says why it gave none (no grasp, events out of order after alignment).
    """

    name: str
    skipped: str | None = None
    t_source_s: tuple[float, float] | None = field(default=None, metadata={"unit": "s"})
    t_model_s: tuple[float, float] | None = field(default=None, metadata={"unit": "s"})


@dataclass(frozen=True)
class GraspEventsFound(Fact):
    """What :mod:`dexlfd.learn.events` found per demonstration, and how many had both.

    ``note`` says why the model has no event arrays, when it has none.
    """

    demonstrations: tuple[DemonstrationEvents, ...] = ()
    n_with_events: int = 0
    note: str | None = None
