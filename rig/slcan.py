"""The slcan (Lawicel) ASCII protocol, device side: what a USB-CAN adapter parses from
its host and sends back. python-can's `slcan` interface is the host side; the virtual
rig's sim-rig process uses this to serve CAN over a socket:// link on loopback.

    "O\\r" open, "C\\r" close, "S0".."S8\\r" bitrate, "V\\r" version ...  -> "\\r" (ok)
    "tIIILDD..\\r"  standard frame: 3 hex id, 1 digit length, 2 hex per byte
    "TIIIIIIIILDD..\\r" extended frame
"""
from __future__ import annotations

from .errors import RigError

OK, ERROR = b"\r", b"\a"


def parse_line(line: bytes):
    """One line without its terminator: ("frame", id, extended, data) or ("command", text);
    RigError for anything malformed."""
    try:
        s = line.decode("ascii")
    except UnicodeDecodeError:
        raise RigError(f"slcan: non-ASCII line {line[:20]!r}") from None
    if not s:
        raise RigError("slcan: empty line")
    kind = s[0]
    if kind in "tT":
        n = 3 if kind == "t" else 8
        head = s[1:n + 2]
        if len(head) != n + 1 or not all(c in "0123456789abcdefABCDEF" for c in head):
            raise RigError(f"slcan: bad frame header {s[:12]!r}")
        ident, dlc = int(head[:n], 16), int(head[n], 16)
        payload = s[n + 2:]
        if dlc > 8 or len(payload) != 2 * dlc or (kind == "t" and ident > 0x7FF) or ident > 0x1FFFFFFF:
            raise RigError(f"slcan: bad frame {s[:30]!r}")
        try:
            data = bytes.fromhex(payload)
        except ValueError:
            raise RigError(f"slcan: bad frame data {payload[:20]!r}") from None
        return ("frame", ident, kind == "T", data)
    if kind in "OCLVNFSsZ" and s.isprintable():
        return ("command", s)
    raise RigError(f"slcan: unknown command {s[:12]!r}")


def format_frame(ident: int, data: bytes, extended=False) -> bytes:
    if extended:
        return f"T{ident:08X}{len(data)}{data.hex().upper()}\r".encode()
    return f"t{ident:03X}{len(data)}{data.hex().upper()}\r".encode()
