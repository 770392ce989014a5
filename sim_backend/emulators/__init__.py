"""The devices of a test cell, emulated on the wire protocols a real cell speaks: one
emulator per transport of rig/devices (adding a transport = one driver there, one emulator
here). Each is made by `serve(config, names, plant)`, fills in the configuration's "auto"
addresses, and has `faults` (a set the virtual rig injects into), `service()` (take in what
the controller sent), `publish(readings)` (send one frame per device), `settle(until)` (return once what publish
sent is readable, or at `until` on time.perf_counter: a simulated clock waits for the transport) and `close()`."""
from __future__ import annotations

from sim_backend.emulators import can_nodes, loadcell_amp, modbus_modules

EMULATORS = {"can": can_nodes.serve, "serial": loadcell_amp.serve, "modbus": modbus_modules.serve}
