"""What every transport declares (rig/devices/__init__.py keeps the registry of them)."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Protocol


FRAME_HZ = 1000.0  # frames per second a streaming device sends unless its config says (frame_hz)


def frame_hz(params) -> float:
    return float(params.get("frame_hz", FRAME_HZ))


class Device(Protocol):
    def open(self) -> None: ...
    def poll(self, now: float) -> list: ...
    def close(self) -> None: ...


@dataclass(frozen=True)
class Transport:
    name: str
    schema: dict  # key -> rig.schema.Field: the [devices.NAME] table of this transport
    signals: Callable[[dict], tuple]  # params -> the device's signal names
    drivers: Callable[[dict, bool], dict]  # ({name: config Device}, threaded) -> {name: driver}
    address: Callable[[dict], str]  # params -> where it is, for people
    rate_hz: Callable[[dict, float], float]  # (params, loop rate) -> samples per second of each signal
    takes_setpoints: Callable[[dict], bool] = field(default=lambda p: False)  # the actuator
    max_age: Callable[[dict, float], float] = field(default=lambda p, stale_s: stale_s)  # watchdog [s]
    check: Callable[[dict], tuple | None] = field(default=lambda p: None)  # (key, problem) beyond the schema
