"""The devices of a test cell, emulated on the wire protocols a real cell speaks: one
emulator per transport of rig/devices (adding a transport = one driver there, one emulator
here). Each is made by `serve(config, names, plant)`, fills in the configuration's "auto"
addresses, and has `faults` (a set the virtual rig injects into), `service()` (take in what
the controller sent), `publish(readings)` (send one frame per device), `settle()` (return once what publish sent
is readable: a simulated clock waits for the transport) and `close()`."""
from __future__ import annotations

import socket


def free_port():
    """A TCP port on 127.0.0.1 nobody listens on now."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


from sim_backend.emulators import can_nodes, loadcell_amp, modbus_modules  # noqa: E402  (they use free_port)

EMULATORS = {"can": can_nodes.serve, "serial": loadcell_amp.serve, "modbus": modbus_modules.serve}
