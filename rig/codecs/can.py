"""CAN frame layouts, decoded and encoded through the DBC file (rig/codecs/dyno.dbc, documented
in docs/wiring.md) with cantools: no hand-packed structs."""
from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import cantools

from rig.errors import RigError

DBC = Path(__file__).parent / "dyno.dbc"


@lru_cache(maxsize=None)
def database(path=DBC):
    try:
        return cantools.database.load_file(str(path))
    except Exception as e:  # noqa: BLE001 - cantools raises several parser errors
        raise RigError(f"{Path(path).name}: cannot load DBC ({e})") from None


def frame_id(name: str) -> int:
    return database().get_message_by_name(name).frame_id


def encode(name: str, signals: dict, strict=True) -> bytes:
    """strict=False skips cantools' range checks: for emulated devices, whose values are
    clipped to the wire's range already (the checks were a tenth of a simulated run)."""
    try:
        return bytes(database().get_message_by_name(name).encode(signals, strict=strict))
    except Exception as e:  # noqa: BLE001 - cantools raises its own errors and ValueError, per signal
        raise RigError(f"CAN {name}: cannot encode {signals} ({e})") from None


def decode(frame_id: int, data: bytes) -> tuple[str, dict]:
    """(message name, {signal: physical value}) of one frame; RigError for an unknown id
    or a malformed payload."""
    db = database()
    try:
        msg = db.get_message_by_frame_id(frame_id)
    except KeyError:
        raise RigError(f"CAN id 0x{frame_id:03X}: not in {DBC.name}") from None
    try:
        return msg.name, msg.decode(bytes(data), decode_choices=False)
    except Exception as e:  # noqa: BLE001 - cantools raises its own errors and ValueError, per signal
        raise RigError(f"CAN {msg.name}: bad payload {bytes(data).hex()} ({e})") from None
