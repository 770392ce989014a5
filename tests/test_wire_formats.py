"""Wire formats: byte-exact examples, round trips, and random or corrupted bytes that must
give a value or the project's own RigError, never anything else."""
import struct

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rig.codecs import can as can_codec
from rig.codecs import loadcell as serial_frame
from rig.codecs import registers as modbus_map
from rig.errors import RigError

# --- serial load-cell frames ---------------------------------------------------------------


def test_serial_frame_is_byte_exact():
    # CRC-16/CCITT-FALSE check value of "123456789" is 0x29B1
    assert serial_frame.crc16(b"123456789") == 0x29B1
    f = serial_frame.encode(7, serial_frame.SATURATED, 1.25)
    body = bytes([7, 1]) + struct.pack("<i", 1_250_000)
    assert f == b"\xaa\x55" + body + struct.pack("<H", serial_frame.crc16(body))
    assert serial_frame.decode(f) == serial_frame.Frame(7, 1, 1.25)


@given(st.lists(st.tuples(st.integers(0, 255), st.integers(0, 3), st.integers(-10**9, 10**9)), max_size=20),
       st.lists(st.binary(max_size=30), max_size=20), st.integers(1, 17))
def test_serial_parser_recovers_every_frame_from_garbage(frames, garbage, chunk):
    encoded = [serial_frame.encode(s, st_, uv * 1e-6) for s, st_, uv in frames]
    stream = b"".join(g + f for g, f in zip(garbage + [b""] * len(encoded), encoded))
    p = serial_frame.FrameParser()
    got = []
    for i in range(0, len(stream), chunk):  # bytes arrive in arbitrary pieces
        got += p.feed(stream[i:i + chunk])
    want = [serial_frame.Frame(s, st_, uv * 1e-6) for s, st_, uv in frames]
    # garbage may contain a valid-looking frame by chance, never lose a real one
    it = iter(got)
    assert all(any(g == w for g in it) for w in want)


@given(st.binary(max_size=400))
def test_serial_parser_takes_any_bytes(data):
    p = serial_frame.FrameParser()
    for f in p.feed(data):
        assert isinstance(f, serial_frame.Frame)
    assert p.dropped <= len(data)


@given(st.binary(max_size=12))
def test_serial_decode_returns_or_raises_rig_error(data):
    try:
        serial_frame.decode(data)
    except RigError:
        pass


def test_corrupted_serial_frames_are_counted_not_returned():
    good = serial_frame.encode(1, 0, 0.5)
    bad = bytearray(serial_frame.encode(2, 0, 0.7))
    bad[5] ^= 0x10  # one flipped bit
    truncated = serial_frame.encode(3, 0, 0.9)[:6]
    p = serial_frame.FrameParser()
    frames = p.feed(good + bytes(bad) + truncated + serial_frame.encode(4, 0, 1.1))
    assert [f.seq for f in frames] == [1, 4]
    assert p.bad_frames >= 1


# --- CAN (DBC via cantools) ----------------------------------------------------------------


def test_can_frames_round_trip_through_the_dbc():
    data = can_codec.encode("ACT_CMD", {"setpoint": 0.0381, "mode": 2, "counter": 9})
    assert data == struct.pack("<iBB", 38100, 2, 9) + b"\x00\x00"
    name, sig = can_codec.decode(can_codec.frame_id("ACT_CMD"), data)
    assert name == "ACT_CMD" and sig["setpoint"] == pytest.approx(0.0381) and sig["mode"] == 2
    name, sig = can_codec.decode(0x110, can_codec.encode("DAQ_MOTION", {"lvdt": -1.5, "lvt": 2.25,
                                                                      "status": 1, "counter": 255}))
    assert sig["lvdt"] == pytest.approx(-1.5) and sig["lvt"] == pytest.approx(2.25) and sig["status"] == 1


@given(st.integers(0, 0x7FF), st.binary(max_size=8))
def test_can_decode_returns_or_raises_rig_error(frame_id, data):
    try:
        name, sig = can_codec.decode(frame_id, data)
    except RigError:
        return
    assert name in ("ACT_CMD", "ACT_STATUS", "DAQ_MOTION") and isinstance(sig, dict)


# --- Modbus register maps ------------------------------------------------------------------


@pytest.mark.parametrize("name", ["tc-module", "analog-module"])
def test_register_maps_round_trip(name):
    m = modbus_map.load(name)
    values = {v.name: 1.5 * (i + 1) for i, v in enumerate(m.values)}
    out = modbus_map.decode(m, modbus_map.encode(m, values, faults=(m.values[0].name,)))
    for v in m.values:
        assert out[v.name][0] == pytest.approx(values[v.name], abs=v.scale)
    assert out[m.values[0].name][1] is not None and out[m.values[1].name][1] is None


def test_thermocouple_registers_are_byte_exact():
    m = modbus_map.load("tc-module")
    regs = modbus_map.encode(m, {"tc1": 93.5})
    assert regs[:2] == list(struct.unpack(">HH", struct.pack(">f", 93.5)))  # high word first


def test_analog_input_saturates_and_flags_over_range():
    m = modbus_map.load("analog-module")
    out = modbus_map.decode(m, modbus_map.encode(m, {"ai2": 40.0}))
    assert out["ai2"] == (pytest.approx(32767 * 0.0005), "input over range")


@settings(max_examples=300)
@given(st.sampled_from(["tc-module", "analog-module"]), st.lists(st.integers(-5, 70000), max_size=12))
def test_register_decode_returns_or_raises_rig_error(name, regs):
    m = modbus_map.load(name)
    try:
        out = modbus_map.decode(m, regs)
    except RigError:
        return
    assert set(out) == {v.name for v in m.values}


def test_unknown_register_map_is_named():
    with pytest.raises(RigError, match="unknown register map 'tc-modul'"):
        modbus_map.load("tc-modul")


# --- socketcand (the sim-rig's CAN link) ---------------------------------------------------


def test_socketcand_messages_are_byte_exact():
    from rig.codecs import socketcand
    assert socketcand.parse("< send 100 8 a 0 0 0 2 9 0 0 >") == ("send", 0x100, bytes([10, 0, 0, 0, 2, 9, 0, 0]))
    assert socketcand.parse("< open can0 >") == ("open", "can0")
    assert socketcand.frame(0x101, bytes([0x90, 0xD0]), 12.5) == "< frame 101 12.500000 90D0 >"
    msgs, rest = socketcand.split_messages("junk< rawmode >< send 1 0 >< sen")
    assert msgs == ["< rawmode >", "< send 1 0 >"] and rest == "< sen"


@given(st.text(max_size=80))
def test_socketcand_parse_returns_or_raises_rig_error(text):
    from rig.codecs import socketcand
    msgs, rest = socketcand.split_messages(text)
    assert len(rest) <= 256
    for m in msgs + [text]:
        try:
            socketcand.parse(m)
        except RigError:
            pass


@given(st.integers(0, 0x7FF), st.binary(max_size=8))
def test_python_can_socketcand_client_frames_parse(ident, data):
    # what python-can's socketcand client sends, we parse back to the same frame
    import can
    from can.interfaces.socketcand.socketcand import convert_can_message_to_ascii_message
    from rig.codecs import socketcand
    text = convert_can_message_to_ascii_message(can.Message(arbitration_id=ident, data=data, is_extended_id=False))
    assert socketcand.parse(text) == ("send", ident, data)


def test_the_wiring_page_examples_are_what_we_send():
    from pathlib import Path
    page = Path(__file__).parents[1].joinpath("docs/wiring.md").read_text()
    cmd = can_codec.encode("ACT_CMD", {"setpoint": 0.0381, "mode": 2, "counter": 9}).hex(" ").upper()
    assert f"`{cmd}`" in page
    assert f"`{serial_frame.encode(7, 1, 1.25).hex(' ').upper()}`" in page


def _mcap(batches, chunk_size, batched):
    """An MCAP file of `batches` [(channel, [(log time, data)])], by add_messages or by
    add_message one message at a time."""
    from io import BytesIO

    from mcap.writer import CompressionType, Writer

    from records.mcap_batch import add_messages
    out = BytesIO()
    w = Writer(out, chunk_size=chunk_size, compression=CompressionType.NONE)
    w.start(profile="", library="test")
    schema = w.register_schema("s", "jsonschema", b"{}")
    ids = [w.register_channel(f"/c{i}", "json", schema) for i in range(3)]
    seq = [0, 0, 0]
    for c, msgs in batches:
        if batched:
            add_messages(w, ids[c], [t for t, _ in msgs], [d for _, d in msgs], seq[c])
        else:
            for i, (t, d) in enumerate(msgs):
                w.add_message(ids[c], t, d, t, sequence=seq[c] + i)
        seq[c] += len(msgs)
    w.finish()
    return out.getvalue()


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 2), st.lists(st.tuples(st.integers(0, 2**40), st.binary(max_size=40)),
                                                          max_size=30)), max_size=12),
       st.integers(1, 600))
def test_plot_messages_written_in_batches_are_the_bytes_add_message_writes(batches, chunk_size):
    # chunks of a few messages: every way a batch can meet a chunk's end
    assert _mcap(batches, chunk_size, True) == _mcap(batches, chunk_size, False)
