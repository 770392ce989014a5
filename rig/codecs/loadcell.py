"""The load-cell amplifier's serial stream (docs/wiring.md): binary frames at 1 kHz.

    offset  size  field
    0       2     sync 0xAA 0x55
    2       1     sequence number (uint8, wraps)
    3       1     status: bit 0 input saturated, bit 1 sensor fault (open bridge)
    4       4     amplifier output [uV], int32 little-endian
    8       2     CRC-16/CCITT-FALSE of bytes 2..7, little-endian

Frames are found by sync and checksum, not by line ends: the payload may hold any byte.
A parser fed garbage resynchronises on the next valid frame and counts what it dropped.
"""
from __future__ import annotations

import binascii
import struct
from dataclasses import dataclass

from rig.errors import RigError

SYNC = b"\xaa\x55"
SIZE = 10
SATURATED, SENSOR_FAULT = 1, 2


def crc16(data: bytes) -> int:
    """CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF): binascii's CRC-CCITT with that init."""
    return binascii.crc_hqx(data, 0xFFFF)


@dataclass(frozen=True)
class Frame:
    seq: int
    status: int
    volts: float  # amplifier output [V]


def encode(seq: int, status: int, volts: float) -> bytes:
    uv = int(round(volts * 1e6))
    if not -2**31 <= uv < 2**31:
        raise RigError(f"load-cell frame: {volts} V out of range")
    body = struct.pack("<BBi", seq & 0xFF, status & 0xFF, uv)
    return SYNC + body + struct.pack("<H", crc16(body))


def decode(frame: bytes) -> Frame:
    """One complete frame; RigError if it is not one."""
    if len(frame) != SIZE or frame[:2] != SYNC:
        raise RigError(f"load-cell frame: bad length or sync ({frame[:SIZE].hex()})")
    body = frame[2:8]
    (crc,) = struct.unpack("<H", frame[8:10])
    if crc != crc16(body):
        raise RigError(f"load-cell frame: checksum mismatch ({frame.hex()})")
    seq, status, uv = struct.unpack("<BBi", body)
    return Frame(seq, status, uv * 1e-6)


class FrameParser:
    """Incremental: feed() bytes as they arrive, get the complete valid frames back."""

    def __init__(self):
        self.buf = bytearray()
        self.dropped = 0  # bytes discarded while resynchronising
        self.bad_frames = 0  # sync found but checksum wrong

    def feed(self, data: bytes) -> list[Frame]:
        self.buf += data
        frames = []
        while True:
            i = self.buf.find(SYNC)
            if i < 0:  # keep a trailing 0xAA: it may start the next sync
                keep = 1 if self.buf[-1:] == SYNC[:1] else 0
                self.dropped += len(self.buf) - keep
                del self.buf[:len(self.buf) - keep]
                return frames
            if i:
                self.dropped += i
                del self.buf[:i]
            if len(self.buf) < SIZE:
                return frames
            try:
                frames.append(decode(bytes(self.buf[:SIZE])))
                del self.buf[:SIZE]
            except RigError:
                self.bad_frames += 1
                self.dropped += 1
                del self.buf[:1]  # not a frame: look for the next sync
