"""Bytes on the wires, as data: the CAN frames (dyno.dbc), the load-cell amplifier's
serial frame, the Modbus register maps (registers/*.toml), the socketcand messages, and
the actuator's modes, states and alarm bits. No I/O here: drivers and emulators both use
these, and the byte-exact tests check them without a device."""
