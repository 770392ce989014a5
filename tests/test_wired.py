"""A real cell's path end to end: `dyno sim-rig` as its own process, `dyno run --rig`
against it over socketcand, a pseudo-terminal and Modbus TCP, then report, identify and
diagnose on the recording; and one fault per transport through the same path, each
ending tripped, safe, with a non-zero exit and the recording intact up to the fault."""
import json
import re
import subprocess
import sys
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from records.events import from_wire
from protocols.plan import STALLED_SHARE
from sim_backend.virtual_rig import sim_rig_config
from tests.conftest import stop

# against a process on real time: run apart from the parallel part of the suite (Makefile)
pytestmark = pytest.mark.realtime

DYNO = str(Path(sys.executable).parent / "dyno")
# one cycle each to ramp in and settle (2 by default): the real time this part of the suite waits on
SINE = ["sine-matrix", "amplitudes_mm=6.4,4.8,3.2", "freqs_hz=2,8", "ramp_cycles=1", "settle_cycles=1", "record_cycles=4"]


def read(path):
    """(events, {channel: (t, value)}, setpoint times, metadata, log times [ns])."""
    events, chans, sp, logs = [], {}, [], []
    with open(path, "rb") as f:
        r = make_reader(f)
        meta = {m.name: dict(m.metadata) for m in r.iter_metadata()}
        for _, ch, m in r.iter_messages():
            logs.append(m.log_time)
            if ch.topic.startswith("/plot/"):  # one message per sample, repeating the batches
                continue
            d = json.loads(m.data)
            if ch.topic == "/events":
                events.append(from_wire(d))
            elif ch.topic == "/actuator/setpoint":
                sp += d["t"]
            elif ch.topic.startswith("/channels/"):
                t, v = chans.setdefault(ch.topic.split("/")[-1], ([], []))
                t += d["t"]
                v += d["value"]
    return events, {k: (np.array(t), np.array(v)) for k, (t, v) in chans.items()}, np.array(sp), meta, logs


def dyno(*args, timeout=300):
    return subprocess.run([DYNO, *map(str, args)], capture_output=True, text=True, timeout=timeout)


def test_a_wired_run_is_one_clock_and_report_identify_diagnose_use_it(tmp_path, sim_rig):
    # the CI machine is a VM that stalls up to ~40 ms now and then: this test is about the path
    cfg = sim_rig_config(tmp_path, stale_s=0.25)
    rig = sim_rig(cfg)
    out = tmp_path / "wired.mcap"
    p = dyno("run", *SINE, "--rig", cfg, "--out", out)
    stop(rig)
    assert p.returncode == 0, p.stderr[-2000:]
    events, ch, sp, meta, logs = read(out)
    # one clock: events, setpoints and every channel's samples share it
    t_first = min(t[0] for t, _ in ch.values())
    t_last = max(t[-1] for t, _ in ch.values())
    # (a frame the device sent just before the rig opened is dated by its counter, before 0)
    assert -0.02 <= t_first < 1.0 and events[0].kind == "run_start" and events[-1].kind == "run_end"
    for e in events:
        assert t_first - 0.1 <= e.t <= t_last + 0.1, e
    assert sp[0] >= t_first - 0.1 and sp[-1] <= t_last + 0.1
    for name, (t, _) in ch.items():
        assert np.all(np.diff(t) >= 0), name
    # absolute log times: the date of the run, as any MCAP tool shows it
    start = datetime.fromisoformat(meta["run"]["wall_start"])
    assert abs((datetime.now(timezone.utc) - start).total_seconds()) < 600
    assert min(logs) / 1e9 == pytest.approx(start.timestamp(), abs=2.0)
    # the same run on the embedded rig, and the three analyses of the wired one, side by side:
    # the real-time part is done, and the second core is free
    emb = tmp_path / "embedded.mcap"
    embedded, report, identify, diagnose = [
        subprocess.Popen([DYNO, *map(str, args)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        for args in (["run", *SINE, "--out", emb], ["report", out, "--out", tmp_path / "report"],
                     ["identify", out, "--json", "--out", tmp_path / "wired.model.json"], ["diagnose", out, "--json"])]
    (_, err), code = embedded.communicate(timeout=300), embedded.returncode
    assert code == 0, err[-2000:]
    e_events, e_ch, *_ = read(emb)
    assert set(e_ch) == set(ch)
    assert [e.segment for e in e_events if e.kind == "segment_start"] == \
           [e.segment for e in events if e.kind == "segment_start"]
    (_, err), code = report.communicate(timeout=300), report.returncode
    assert code == 0 and (tmp_path / "report" / "loops.png").exists(), err
    (text, err), code = identify.communicate(timeout=300), identify.returncode
    assert code == 0, err[-2000:]
    doc = json.loads(text)
    assert "0 sine segments" not in err and doc["heldout_nrmse"] < 0.05, doc["heldout_nrmse"]
    (_, err), code = diagnose.communicate(timeout=300), diagnose.returncode
    assert code == 0, err[-2000:]


def test_the_dyno_runs_its_own_next_tests_on_the_wires(tmp_path, sim_rig):
    """`dyno run discover --rig`: an opening, then the sines the diagnosis asks for, on the
    same cell into the same recording (protocols/discover.py)."""
    cfg = sim_rig_config(tmp_path, stale_s=0.25)  # the VM's stalls, as above
    # a fast sine whose plant stalls that long jumps past the velocity limit on catching up:
    # the cell's stroke and frequency limits keep the next tests slow (5 mm at 4 Hz at most)
    cfg.write_text(cfg.read_text().replace("velocity_max = 1.5", "velocity_max = 1.5\nfrequency_max = 4.0")
                   .replace("x_min = 0.002 ", "x_min = 0.0315").replace("x_max = 0.074", "x_max = 0.0447"))
    sim_rig(cfg)
    out = tmp_path / "discover.mcap"
    p = dyno("run", "discover", "amplitudes_mm=6.4", "freqs_hz=2,4", "record_cycles=6", "--budget", 3,
             "--rig", cfg, "--out", out)
    assert p.returncode == 0, p.stderr[-2000:]
    assert "discover: round 1: named" in p.stderr and "recorded" in p.stderr
    events, ch, _, meta, _ = read(out)
    assert meta["protocol"]["name"] == "discover" and events[-1].kind == "run_end"
    told = [e for e in events if e.kind == "next_test"]
    assert told and all("differ by" in e.message for e in told)
    assert sum(e.params["rig_s"] for e in told) <= 3.0
    assert all(e.params["freq_hz"] <= 4.0 and e.params["amplitude_mm"] <= 5 for e in told)
    # each sine asked for is recorded after its reason, in the same file and on the same clock
    for e in told:
        start = next(s for s in events if s.kind == "segment_start" and s.segment == e.segment)
        assert start.t > e.t and start.t < ch["force"][0][-1]
    p = dyno("report", out, "--out", tmp_path / "report")
    assert p.returncode == 0 and "round 1: ran" in (tmp_path / "report" / "index.html").read_text(), p.stderr


@pytest.mark.parametrize("fault, message, stale_s", [
    # both CAN nodes fall silent: the conditioner's x or the actuator's x_internal is stale first
    ("can_bus_off", "watchdog: x", None),
    ("serial_corrupt", "device 'loadcell': serial line corrupt", 0.25),
    ("modbus_timeout", "Modbus request failed", 0.25),
])
def test_a_fault_on_each_transport_trips_safely_and_keeps_the_recording(tmp_path, sim_rig, fault, message, stale_s):
    cfg = sim_rig_config(tmp_path, stale_s=stale_s)  # None: the shipped 50 ms watchdog
    sim_rig(cfg, "--fault", f"{fault}@5")
    out = tmp_path / "fault.mcap"
    p = dyno("run", "sine-matrix", "amplitudes_mm=6.4", "freqs_hz=2", "record_cycles=12", "--rig", cfg,
             "--out", out, timeout=120)
    assert p.returncode == 1 and "Traceback" not in p.stderr, p.stderr[-2000:]
    assert p.stderr.strip().splitlines()[-1].startswith("dyno: run stopped: "), p.stderr[-500:]
    stolen = re.search(r"loop stalled for (\d+) ms.* the hypervisor took (\d+) ms", p.stderr.strip().splitlines()[-1])
    if message not in p.stderr and stolen and int(stolen[2]) >= int(stolen[1]) / 2:
        # the loop's stall, by the scheduler's view, was the host's: not the loop's, nor the fault's
        pytest.skip(f"this host did not keep real time: {stolen[0]}")
    assert message in p.stderr.strip().splitlines()[-1]
    events, ch, sp, meta, _ = read(out)  # the indexed reader: the file was finished
    kinds = [e.kind for e in events]
    assert kinds[-2:] == ["fault", "run_end"] and message in events[-2].message
    t_fault = events[-2].t
    assert 1.0 < t_fault < 12.0
    assert ch["force"][0][-1] > t_fault + 0.15 or fault == "serial_corrupt"  # recorded on through the stop
    if fault == "can_bus_off":
        t_x = ch["x"][0]
        last = t_x[t_x <= t_fault][-1]
        assert t_fault - last <= 0.100, t_fault - last  # tripped within 100 ms of the last frame


def test_rig_check_refuses_a_wrong_unit_id_and_flags_implausible_readings(tmp_path, sim_rig):
    cfg = sim_rig_config(tmp_path, stale_s=0.25)
    sim_rig(cfg)
    text = cfg.read_text()
    same_id = tmp_path / "same-id.toml"  # two devices at one address: refused before anything connects
    same_id.write_text(text.replace("device_id = 2", "device_id = 1"))
    p = dyno("rig", "check", "--rig", same_id, timeout=60)
    assert p.returncode == 2 and "id 1 is taken by device 'tc'" in p.stderr, p.stderr
    wrong_id = tmp_path / "wrong-id.toml"  # the two modules' ids swapped: each answers as the other
    wrong_id.write_text(text.replace("device_id = 1", "device_id = @").replace("device_id = 2", "device_id = 1")
                        .replace("device_id = @", "device_id = 2"))
    p = dyno("rig", "check", "--rig", wrong_id, timeout=60)
    assert p.returncode == 2 and "Traceback" not in p.stderr
    assert ("device 'analog': Modbus unit 1" in p.stderr and "identifies as 0x5443, not the analog-module's 0x4149"
            in p.stderr) or ("device 'tc': Modbus unit 2" in p.stderr and "identifies as 0x4149, not the "
                             "tc-module's 0x5443" in p.stderr), p.stderr
    no_offset = tmp_path / "no-offset.toml"  # degC read as K: 20 K is no damper's temperature
    no_offset.write_text(text.replace("offset = 273.15         # degC -> K", "offset = 0.0", 1))
    p = dyno("rig", "check", "--rig", no_offset, timeout=60)
    assert p.returncode == 1, p.stdout + p.stderr
    line = next(ln for ln in p.stdout.splitlines() if ln.startswith("T_body"))
    assert "IMPLAUSIBLE: outside -100..500 C" in line and " -25" in line  # about -253 C: shown in the operator's C
    assert "T_body (tc: implausible" in p.stderr and len(p.stderr.strip().splitlines()) == 1


def test_hardware_in_the_loop_over_the_wires(tmp_path, sim_rig):
    """The car around the damper of a separate `dyno sim-rig`, in real time over
    socketcand, the pseudo-terminal and Modbus TCP: it tracks."""
    cfg = sim_rig_config(tmp_path)
    sim_rig(cfg)
    out = tmp_path / "hil.mcap"
    p = dyno("run", "hil", "--road", "iso8608:C:50:3", "--rig", cfg, "--out", out)
    late = re.search(r"real time: (\d+) of (\d+) ticks late", p.stderr)
    if p.returncode and late and int(late[1]) > 0.03 * int(late[2]):
        # a host that misses more than 3 % of its ticks (passing runs here: 1.5 % at most)
        # tells nothing about the loop: a stall of tens of ms moves the car past the guard
        pytest.skip(f"this host did not keep real time: {late[0]}")
    events, ch, _, _, _ = read(out)  # the road's result is recorded also when the guard stops it
    m = next((e.params for e in events if e.kind == "result"), None)
    # the goal is 3 % (measured 1.2-3.1 % here: late ticks of a VM count); 5 % still tells a
    # loop that tracks from one that does not (none: 14-16 %). A run whose loop stalled so
    # often that the run itself says its host did not keep real time (protocols/plan.py
    # said_stalled) tells nothing of the loop, whether it ended or its guard stopped it (a
    # 3x slower host beside another test: 2.7 % of the ticks late, 39 % of the road's just
    # after a stall, the guard tripped)
    if m is not None and (m["j2"] >= 0.05 or p.returncode) and m["stalled"] > STALLED_SHARE:
        pytest.skip(f"this host did not keep real time: {100 * m['stalled']:.0f} % of the ticks after stalls, "
                    f"J2 {100 * m['j2']:.2f} %")
    assert p.returncode == 0, p.stderr[-2000:]
    # it ran the whole road (a tick or two may fall to a late wake-up on a loaded VM)
    assert m["j2"] < 0.05 and m["steps"] >= 3950, m
    t = ch["hil.x_target"][0]
    assert np.all(np.diff(t) > 0) and t[-1] - t[0] > 3.9  # one car step per tick, on the run clock


def test_replay_over_the_wires_converges(tmp_path, sim_rig):
    """`dyno run replay --rig` against `dyno sim-rig` in real time: the drive corrected
    between iterations brings the damper onto the target history."""
    from test_hil import _target_csv
    cfg = sim_rig_config(tmp_path, stale_s=0.25)
    sim_rig(cfg)
    out = tmp_path / "replay.mcap"
    p = dyno("run", "replay", "--target", _target_csv(tmp_path), "--iterations", "3", "--rig", cfg, "--out", out)
    assert p.returncode == 0, p.stderr[-2000:]
    events, _, _, _, _ = read(out)
    results = [e.params for e in events if e.kind == "result"]
    # the convergence is the drive's, judged without the ticks the actuator spent catching up
    # after a stall of the control loop (one 59 ms stall made a converged 0.37 % iteration 4.08 %)
    errors = [r["nrmse_undisturbed"] for r in results]
    stalled = [r["stalled"] for r in results]
    if len(errors) == 3 and errors[-1] >= 0.03 and max(stalled) > STALLED_SHARE:
        # the iteration's own stalls are not the rig's to learn: over the wires here, iterations
        # with 11-17 % of their ticks just after a stall reached 1-2 %; 23-31 % gave 3.7 %
        pytest.skip(f"this host did not keep real time: {stalled} of the ticks after stalls, errors {errors}")
    assert len(errors) == 3 and errors[-1] < 0.03 and errors[-1] < errors[0] / 3, (errors, stalled)


def test_rig_zero_tares_references_and_writes_the_cell_file(tmp_path, sim_rig):
    cfg = sim_rig_config(tmp_path)
    sim_rig(cfg)
    # (--tare-anyway: the sim-rig's damper cannot be disconnected, its gas force is tared as a zero error)
    p = dyno("rig", "zero", "--rig", cfg, "--unloaded", "--tare-anyway", "--x-mm", "39", timeout=120)
    assert p.returncode == 0, p.stdout + p.stderr
    assert "the LVT reads" in p.stdout and f"written to {cfg}" in p.stdout
    from rig import config as rig_config
    zeroed = rig_config.load(cfg)  # still a valid cell file, with the dated reasons beside the offsets
    text = cfg.read_text()
    assert text.count("# dyno rig zero ") == 2 and "load cell tared with the damper disconnected" in text
    assert zeroed.channels["force"].offset < -100  # the damper's gas force at rest, taken off
    # the cell now reads 39 mm at mid-stroke, and at rest no gas force (420 N) is left, only
    # the seal's friction (up to +-70 N here, its sign set by the last motion: the sim-rig's
    # damper cannot be disconnected)
    p = dyno("rig", "check", "--rig", cfg, timeout=60)
    rows = {ln.split()[0]: ln.split() for ln in p.stdout.splitlines() if ln.split()}
    assert abs(float(rows["force"][2])) < 200 and abs(float(rows["x"][2]) - 39.0) < 0.2
