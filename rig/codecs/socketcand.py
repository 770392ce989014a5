"""The socketcand protocol (ASCII over TCP), server side: what a socketcand daemon
parses from its client and sends back. python-can's `socketcand` interface is the client
side; `dyno sim-rig` uses this to serve its CAN bus on 127.0.0.1.

    server: "< hi >"                      client: "< open can0 >"   -> "< ok >"
                                           client: "< rawmode >"     -> "< ok >"
    client: "< send 100 8 a 0 0 0 2 9 0 0 >"   a frame to the bus (id hex, length, bytes hex)
    server: "< frame 101 12.345678 90D0030200070000 >"   a frame from the bus
"""
from __future__ import annotations

from rig.errors import RigError


def split_messages(buffer: str):
    """(complete "< ... >" messages, rest of the buffer); text outside them is dropped."""
    out = []
    while True:
        start = buffer.find("<")
        if start < 0:
            return out, ""
        end = buffer.find(">", start)
        if end < 0:
            return out, buffer[start:][-256:]  # an unterminated message cannot grow forever
        out.append(buffer[start:end + 1])
        buffer = buffer[end + 1:]


def parse(message: str):
    """One "< ... >" message from a client: ("send", id, data), ("open", channel),
    ("rawmode",) ...; RigError for anything malformed."""
    if not (message.startswith("<") and message.endswith(">")):
        raise RigError(f"socketcand: not a message {message[:30]!r}")
    words = message[1:-1].split()
    if not words:
        raise RigError("socketcand: empty message")
    if words[0] == "send":
        try:
            ident, n = int(words[1], 16), int(words[2], 16)
            data = bytes(int(b, 16) for b in words[3:])
        except (IndexError, ValueError):
            raise RigError(f"socketcand: bad send {message[:40]!r}") from None
        if n != len(data) or n > 8 or not 0 <= ident <= 0x1FFFFFFF:
            raise RigError(f"socketcand: bad send {message[:40]!r}")
        return ("send", ident, data)
    if words[0] == "open" and len(words) == 2:
        return ("open", words[1])
    if words[0] in ("rawmode", "echo") and len(words) == 1:
        return (words[0],)
    raise RigError(f"socketcand: unsupported message {message[:30]!r}")


def frame(ident: int, data: bytes, t: float) -> str:
    width = 8 if ident > 0x7FF else 3
    return f"< frame {ident:0{width}X} {t:.6f} {data.hex().upper()} >"
