"""A run's events as typed records: what the runner, the safety chain and the analyses
tell a recording, and what every reader gets back from one (docs/recording.md).

On the wire (the MCAP topic /events) each event is one JSON object {t, kind, segment,
params, message}; `wire` writes it and `from_wire` reads it back as the same class, from
recordings of any age. Readers tell events apart by their class and read their fields,
never a key or a sentence.
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields, replace
from typing import ClassVar


@dataclass(frozen=True)
class Event:
    t: float  # s, run clock
    segment: str = ""  # the segment or protocol it concerns
    params: dict = field(default_factory=dict)  # the segment's parameters, or the finding's body
    message: str = ""
    kind: ClassVar[str] = ""

    def wire(self) -> dict:
        """The JSON object /events carries: a kind's own fields ride in params."""
        own = {f.name: getattr(self, f.name) for f in fields(self) if f.name not in _BASE}
        return {"t": self.t, "kind": self.kind, "segment": self.segment, "params": {**self.params, **own},
                "message": self.message}

    def shifted(self, dt: float) -> Event:
        return replace(self, t=self.t + dt)


_BASE = {f.name for f in fields(Event)}


@dataclass(frozen=True)
class RunStart(Event):
    """A protocol started (segment: its name; params: its parameters)."""
    kind: ClassVar[str] = "run_start"
    segment_count: int = 0  # 0: a recording from before the count was written
    duration_max_s: float = 0.0  # s, the plan's length if no segment ends early


@dataclass(frozen=True)
class SegmentStart(Event):
    """A segment of the plan started; params are its parameters with its kind."""
    kind: ClassVar[str] = "segment_start"

    @property
    def measured(self) -> bool:
        return bool(self.params.get("measured", True))


@dataclass(frozen=True)
class SegmentEnd(Event):
    kind: ClassVar[str] = "segment_end"


@dataclass(frozen=True)
class Skipped(Event):
    """A segment the plan's check left out, or an analysis that could not judge one (message: why)."""
    kind: ClassVar[str] = "skipped"


@dataclass(frozen=True)
class ClosedLoopResult(Event):
    """What a closed-loop segment measured once the rig was safe (params: the segment's
    parameters and its measures)."""
    kind: ClassVar[str] = "result"
    protocol: str = ""  # the closed loop's protocol: "hil", "replay"

    @property
    def of(self) -> str:
        """The protocol that measured; for a recording from before the field, told by its
        measures, in this one place."""
        return self.protocol or ("hil" if "j2" in self.params else "replay" if "nrmse" in self.params else "")


@dataclass(frozen=True)
class Fault(Event):
    """The run tripped (message: why)."""
    kind: ClassVar[str] = "fault"


@dataclass(frozen=True)
class OperatorStop(Event):
    kind: ClassVar[str] = "operator_stop"


@dataclass(frozen=True)
class RunEnd(Event):
    """The protocol ended (message: "completed" or the fault)."""
    kind: ClassVar[str] = "run_end"


@dataclass(frozen=True)
class Findings(Event):
    """A diagnosis's findings: one sine segment's while the rig runs (source "live"), or a
    discovery round's."""
    kind: ClassVar[str] = "diagnosis"
    source: str = ""  # "live": beside the rig, one segment against the damper's model

    @property
    def live(self) -> bool:
        return self.source == "live"


@dataclass(frozen=True)
class NextTest(Event):
    """A test a discovery proposes (segment: the sine; message: what it separates)."""
    kind: ClassVar[str] = "next_test"


@dataclass(frozen=True)
class DiscoveryVerdict(Event):
    """What a discovery ends with."""
    kind: ClassVar[str] = "verdict"


@dataclass(frozen=True)
class Other(Event):
    """An event of a kind this version does not know (a newer writer's): kept and shown."""
    name: str = ""

    @property
    def kind(self) -> str:  # type: ignore[override]
        return self.name

    def wire(self) -> dict:
        return {"t": self.t, "kind": self.name, "segment": self.segment, "params": self.params,
                "message": self.message}


KINDS = {c.kind: c for c in (RunStart, SegmentStart, SegmentEnd, Skipped, ClosedLoopResult, Fault, OperatorStop, RunEnd,
                             Findings, NextTest, DiscoveryVerdict)}
STOPS = (Fault, OperatorStop)  # how a run ends early


def from_wire(d: dict) -> Event:
    """The event a /events JSON object holds ({t, kind, segment, params, message}, checked
    by the reader)."""
    cls = KINDS.get(d["kind"])
    params = dict(d.get("params") or {})
    common = {"t": float(d["t"]), "segment": d.get("segment", ""), "message": d.get("message", "")}
    if cls is None:
        return Other(params=params, name=d["kind"], **common)
    own = {f.name: params.pop(f.name) for f in fields(cls) if f.name not in _BASE and f.name in params}
    return cls(params=params, **own, **common)
