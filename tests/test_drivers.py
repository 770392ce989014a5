"""The drivers against in-memory transports, without a device or an emulator: what the
driver sends is byte-exact, what it receives becomes the right readings and faults, and
bad bytes are faults, not exceptions. (The same drivers against the emulators: the wired
and virtual-rig tests.)"""
import itertools
import os
import time

import can
import pytest

from rig.codecs import can as can_codec
from rig.codecs import loadcell
from rig.codecs.actuator import MODES
from rig.devices.can import CanBus, CanNode
from rig.devices.serial import SerialLoadCell
from rig.errors import RigError

_channels = itertools.count()


@pytest.fixture()
def can_pair():
    """(the driver's bus params, the test's end of the same in-memory bus)."""
    channel = f"drivers-{next(_channels)}"
    params = {"interface": "virtual", "channel": channel}
    other = can.Bus(interface="virtual", channel=channel, receive_own_messages=False)
    yield params, other
    other.shutdown()


def test_the_actuator_node_sends_its_setpoint_byte_exact(can_pair):
    params, other = can_pair
    node = CanNode("actuator", CanBus(params, "device 'actuator'"), "actuator")
    node.open()
    node.send("follow", 0.0381)
    node.send("hold", 0.0)
    sent = [other.recv(timeout=1.0) for _ in range(2)]
    assert [m.arbitration_id for m in sent] == [can_codec.frame_id("ACT_CMD")] * 2
    assert bytes(sent[0].data) == can_codec.encode("ACT_CMD", {"setpoint": 0.0381, "mode": MODES["follow"], "counter": 1})
    assert bytes(sent[1].data) == can_codec.encode("ACT_CMD", {"setpoint": 0.0, "mode": MODES["hold"], "counter": 2})
    node.close()


def test_can_frames_become_readings_dated_by_their_counters(can_pair):
    params, other = can_pair
    bus = CanBus(params, "device 'daq'")
    daq, act = CanNode("daq", bus, "daq"), CanNode("actuator", bus, "actuator")
    daq.open()
    for k in range(3):
        other.send(can.Message(arbitration_id=can_codec.frame_id("DAQ_MOTION"), is_extended_id=False,
                               data=can_codec.encode("DAQ_MOTION", {"lvdt": 1.0 + k, "lvt": -0.5, "status": 2 if k == 2 else 0,
                                                                    "counter": k})))
    other.send(can.Message(arbitration_id=can_codec.frame_id("ACT_STATUS"), is_extended_id=False,
                           data=can_codec.encode("ACT_STATUS", {"position": 0.04, "state": 2, "alarm": 0, "counter": 0})))
    other.send(can.Message(arbitration_id=0x7FF, is_extended_id=False, data=b"\x00"))  # a frame nobody knows
    readings = daq.poll(1.0)
    assert [(s, round(v, 4), f) for s, v, f, _ in readings] == [
        ("lvdt", 1.0, None), ("lvt", -0.5, None), ("lvdt", 2.0, None), ("lvt", -0.5, None),
        ("lvdt", 3.0, None), ("lvt", -0.5, "LVT out of range")]
    ages = [age for *_, age in readings[::2]]
    assert ages == pytest.approx([2e-3, 1e-3, 0.0], abs=1e-9)  # 1 kHz counters: the newest arrived now
    assert act.poll(1.0)[0][:2] == ("position", pytest.approx(0.04, abs=1e-6)) and act.state == (2, 0)
    assert bus.errors == 1
    daq.close()


def _loadcell(url):
    d = SerialLoadCell("loadcell", {"port": url})
    d.open()
    return d


def test_load_cell_frames_become_readings_and_faults():
    d = _loadcell("loop://")
    d.port.write(loadcell.encode(0, 0, 1.25) + loadcell.encode(1, loadcell.SATURATED, 9.99))
    out = d.poll(0.5)
    assert [(s, round(v, 4), f) for s, v, f, _ in out] == [("output", 1.25, None),
                                                           ("output", 9.99, "load cell saturated")]
    assert out[0][3] == pytest.approx(1e-3) and out[1][3] == pytest.approx(0.0)
    d.close()


def test_a_corrupt_serial_line_is_named_not_raised_from_the_parser():
    d = _loadcell("loop://")
    d.port.write(loadcell.encode(0, 0, 1.0))
    assert len(d.poll(0.1)) == 1
    d.port.write(b"\xaa\x55" + bytes(range(200)))  # garbage that even starts like a frame
    with pytest.raises(RigError, match=r"device 'loadcell': serial line corrupt"):
        for _ in range(5):
            d.poll(0.2)
    d.close()


def test_a_load_cell_on_a_real_tty_reads_what_the_line_holds_and_a_split_frame_whole():
    """On a pseudo-terminal the driver reads only the bytes the tty says it holds (TIOCINQ):
    an empty line gives nothing without a read that waits on the kernel, and a frame that
    arrives in two parts is one reading once its second part is there."""
    master, slave = os.openpty()
    d = _loadcell(os.ttyname(slave))
    reads, read = [], d.port.read
    d.port.read = lambda n: reads.append(n) or read(n)  # what the driver asks of the tty
    try:
        assert d.poll(0.1) == [] and d.poll(0.2) == []
        assert reads == []  # nothing asked of an empty line (a read there waits on the kernel)
        frame = loadcell.encode(7, 0, 2.5)
        os.write(master, frame[:3])
        out, deadline = [], time.monotonic() + 5.0
        while time.monotonic() < deadline and d.port.in_waiting < 3:
            time.sleep(1e-3)
        assert d.poll(0.3) == []  # half a frame is no reading
        os.write(master, frame[3:])
        while not out and time.monotonic() < deadline:  # the kernel moves the bytes when it will
            out = d.poll(0.4)
        assert [(s, round(v, 4), f) for s, v, f, _ in out] == [("output", 2.5, None)]
        assert d.poll(0.5) == [] and all(n > 0 for n in reads)
    finally:
        d.close()
        os.close(master)
        os.close(slave)


def test_an_unopenable_serial_port_is_named():
    with pytest.raises(RigError, match=r"device 'loadcell': cannot open serial port '/nonexistent/tty'"):
        _loadcell("/nonexistent/tty")
