"""The rig against the virtual rig in this process, over the real transports (python-can
virtual bus, a pseudo-terminal, Modbus TCP on 127.0.0.1): every channel, motion, and each
injected fault ending in the safe state with its message and the samples kept."""
import os
import re
from pathlib import Path

import numpy as np
import pytest

from rig import config
from rig.loop import ControlLoop
from rig.pacing import SimulatedPacer
from rig.rig import Rig
from rig.safety import Safety
from sim_backend.plant import MODE_HOLD, STATE_ALARM
from sim_backend.virtual_rig import VirtualRig

MID = 0.0381


@pytest.fixture
def cell():
    cfg = config.load("virtual")
    vr = VirtualRig(cfg, damper="koni")
    cfg = vr.start()
    rig = Rig(cfg, clock=vr.clock)
    rig.open()
    yield vr, rig
    rig.close()
    vr.close()


def test_each_tick_reads_its_own_load_cell_frame(cell):
    """The pty hands bytes over on a kernel work queue: without the step's settle, a busy
    machine gives the driver some frames a tick late (a hardware-in-the-loop car then
    steps on a stale force)."""
    vr, rig = cell
    late = 0
    for _ in range(3000):
        vr.step(1e-3)
        now = rig.poll()
        late += now - rig.read()["force"].t > 5e-4
    assert late == 0


class Collector:
    def __init__(self):
        self.t, self.v = {}, {}

    def __call__(self, samples):
        for k, (t, v) in samples.items():
            self.t.setdefault(k, []).extend(t)
            self.v.setdefault(k, []).extend(v)


def run(vr, rig, plan, seconds=None):
    sink = Collector()
    loop = ControlLoop(rig, SimulatedPacer(vr, rig.config.rate_hz), Safety(rig.config), [sink])
    return loop.run(plan, max_s=seconds), sink


def sine(amplitude=0.005, freq=2.0, until=1.0, then=None):
    def plan(t, readings):
        if t >= until:
            return None
        if then is not None and t >= then[0]:
            then[1]()
        return MID + amplitude * np.sin(2 * np.pi * freq * t)
    return plan


def test_every_channel_reports_through_its_transport(cell):
    vr, rig = cell
    for _ in range(300):
        vr.step(1e-3)
        rig.poll()
    r = rig.read()
    assert set(r) == set(rig.config.channels)
    assert r["x"].value == pytest.approx(MID, abs=1e-4) and r["x_internal"].value == pytest.approx(MID, abs=1e-4)
    assert r["force"].value == pytest.approx(vr.plant.F, abs=10.0)  # gas force at rest, about 430 N
    assert r["P_gas"].value == pytest.approx(vr.plant.P[0], rel=0.01)
    assert r["T_body"].value == pytest.approx(293.15, abs=1.0)
    assert rig.actuator() == ("holding", [])


def test_a_sine_is_followed_and_every_sample_kept(cell):
    vr, rig = cell
    res, sink = run(vr, rig, sine(until=1.5))
    assert res.fault is None and res.ticks == pytest.approx(1500, abs=2)
    t, x = np.array(sink.t["x"]), np.array(sink.v["x"])
    assert len(t) == res.ticks  # one LVDT sample per tick, none lost
    late = t > 0.5
    assert (x[late].max() - x[late].min()) / 2 == pytest.approx(0.005, rel=0.1)  # 4 ms lag at 2 Hz: ~1 %
    F = np.array(sink.v["force"])
    assert F.max() - F.min() > 200  # the damper resists the motion
    assert len(sink.v["T_body"]) >= 14 and len(sink.v["P_gas"]) >= 140  # polled at 10 and 100 Hz


FAULTS = [
    # fault, message fragment, whether the controlled move to the safe position is possible
    # (position feedback from a device that did not fail, and the actuator healthy)
    ("can_bus_off", "watchdog: x (conditioner)", False),
    ("serial_corrupt", "device 'loadcell': serial line corrupt", True),
    ("serial_truncate", "device 'loadcell': serial line corrupt", True),
    ("serial_garbage", "force (loadcell): serial line corrupt", True),
    ("modbus_exception", "Modbus exception response", True),
    ("modbus_timeout", "Modbus request failed", True),
    ("open_thermocouple", "T_body (tc): open thermocouple", True),
    ("loadcell_stuck", "force (loadcell): reading frozen", True),
    ("loadcell_saturated", "force (loadcell): load cell saturated", True),
    ("actuator_alarm", "actuator alarm: valve fault", False),
]


def test_a_late_module_does_not_fail_on_the_simulated_clock(cell):
    """The embedded cell's Modbus server answers 150 ms late, as on a machine busy with
    other work (the suite's other processes): the rig's time stands still while it waits,
    so every poll is answered and the run goes on (a 0.1 s timeout failed it)."""
    vr, rig = cell
    vr.inject("modbus_late")
    res, sink = run(vr, rig, sine(until=0.2))
    assert res.fault is None, res.fault
    assert len(sink.v["P_gas"]) >= 19  # polled at 100 Hz, none lost


@pytest.mark.parametrize("fault, message, ramps", FAULTS)
def test_each_fault_ends_in_the_safe_state(cell, fault, message, ramps):
    vr, rig = cell
    res, sink = run(vr, rig, sine(amplitude=0.008, until=3.0, then=(0.6, lambda: vr.inject(fault))))
    assert res.fault is not None and message in res.fault, res.fault
    assert "\n" not in res.fault
    # samples from before the fault are all there: one LVDT and load-cell sample per tick
    t_force = np.array(sink.t["force"])
    assert np.sum(t_force < 0.6) == pytest.approx(600, abs=2)
    p = vr.plant
    if ramps:  # healthy position feedback: parked at the safe position, holding
        assert p.x_act == pytest.approx(rig.config.safe_position, abs=2e-4)
    else:  # no trustworthy feedback or command path: stopped where it was
        assert p.mode == MODE_HOLD or p.state == STATE_ALARM
        assert abs(p.v_act) < 1e-6
    if fault == "actuator_alarm":
        assert p.state == STATE_ALARM
    if fault == "modbus_timeout":  # a late reply to a timed-out request is not the next one's answer
        assert max(sink.t["P_gas"]) <= 0.6 + 1e-9


def test_operator_stop_and_setpoint_limits(cell):
    vr, rig = cell

    def plan(t, readings):
        if t > 0.3:
            raise KeyboardInterrupt
        return MID
    res, _ = run(vr, rig, plan)
    assert res.fault == "operator stop"
    res, _ = run(vr, rig, lambda t, r: 0.09)  # beyond x_max
    assert "setpoint 0.0900 m outside the stroke limits" in res.fault


def test_force_limit_trips(cell):
    vr, rig = cell
    rig.config.limits["force_max"] = 600.0  # gas force alone is about 430 N
    res, _ = run(vr, rig, sine(amplitude=0.01, freq=4.0, until=2.0))
    assert res.fault.startswith("limit: force")
    assert vr.plant.x_act == pytest.approx(rig.config.safe_position, abs=2e-4)


def test_a_run_killed_outright_leaves_no_stall_file_behind(tmp_path):
    """The stall trace's file has a name only once it holds a stall's stacks: a loop killed
    with SIGKILL (nothing of it runs after) leaves nothing in the temporary folder."""
    import signal
    import subprocess
    import sys
    code = ("import sys, time; from rig.stall_trace import StallTrace; t = StallTrace(5.0, 0.001); t.tick(); "
            "print(t.path, flush=True); time.sleep(60)")
    p = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True,
                         env={**os.environ, "TMPDIR": str(tmp_path)})
    assert p.stdout.readline().strip() == "None"  # armed, and no name yet
    p.send_signal(signal.SIGKILL)
    p.wait(timeout=10)
    assert list(tmp_path.iterdir()) == []


def test_the_stall_trace_tells_a_busy_thread_from_a_sleeping_one():
    """The scheduler's view of a stall: a thread that computed through it ran (or, on a busy
    host, waited for a CPU or lost it to the hypervisor); one that slept did neither."""
    import time

    from rig.stall_trace import Clocks, StallTrace
    trace = StallTrace(5.0, 0.001)
    try:
        said = {}
        for how in ("busy", "asleep"):
            trace.tick()  # a look, as the loop takes every few ticks
            t0 = time.monotonic()
            while time.monotonic() - t0 < 0.06:
                if how == "asleep":
                    time.sleep(0.06)
            said[how] = trace.where_the_time_went()
            trace.ticks = 0
        ms = {how: {w: int(re.search(rf"{w} (\d+) ms", text)[1]) for w in ("ran", "waited", "took")}
              for how, text in said.items()}
        assert sum(ms["busy"].values()) >= 50, said["busy"]
        assert ms["asleep"]["ran"] < 10, said["asleep"]
        assert said["asleep"].startswith("in the ") and "other threads ran" in said["asleep"]
    finally:
        assert trace.close() is None
    # where the OS tells nothing, the view says only what it knows
    before = Clocks(0.0, 0.0, 0.0, float("nan"), float("nan"))
    text = Clocks(0.1, 0.05, 0.07, float("nan"), float("nan")).since(before)
    assert text == "in the 100 ms since the loop's last look: the loop ran 50 ms, other threads ran 20 ms"


@pytest.mark.realtime
def test_a_stalled_loop_trips_its_watchdog(cell):
    import time

    from rig.pacing import RealTimePacer
    vr, rig = cell
    stalled = []

    def plan(t, readings):
        if t > 0.3 and not stalled:
            stalled.append(t)
            time.sleep(0.08)  # the control computation hangs for 80 ms
        return None if t > 2.0 else MID
    loop = ControlLoop(rig, RealTimePacer(rig.config.rate_hz, virtual_rig=vr), Safety(rig.config))
    res = loop.run(plan)
    assert res.fault.startswith("watchdog: control loop stalled for") and res.missed >= 70
    # the scheduler's view: the loop slept through it (it did not run, nor wait for a CPU)
    ran, waited = (int(re.search(rf"{w} (\d+) ms", res.fault)[1]) for w in ("the loop ran", "waited"))
    assert ran < 20 and waited < 20, res.fault
    assert vr.plant.x_act == pytest.approx(MID, abs=1e-4)  # held where it was
    # where the process was during the stall: every thread's stack, dumped while it lasted
    assert res.stall_trace and res.stall_trace in res.fault, res.fault
    stacks = Path(res.stall_trace).read_text()
    assert "in plan" in stacks and "test_virtual_rig.py" in stacks, stacks
    Path(res.stall_trace).unlink()
    # a loop that never stalls leaves no file behind
    assert loop.run(lambda t, r: None if t > 0.2 else MID).stall_trace is None


@pytest.mark.realtime
def test_the_embedded_loop_bench_runs_beside_busy_programs_and_stops_them():
    """`dyno bench loop --embedded --busy N`: the busy programs run while the loop does, and
    none is left spinning after it."""
    import os

    from proof.bench.timing import bench_embedded, busy

    def spinning():
        mine = []
        for pid in filter(str.isdigit, os.listdir("/proc")):
            try:
                stat = open(f"/proc/{pid}/stat").read()
                cmd = open(f"/proc/{pid}/cmdline", "rb").read()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == os.getpid() and b"while True: pass" in cmd:
                mine.append(pid)
        return mine
    with busy(2):
        assert len(spinning()) == 2
        stats = bench_embedded(seconds=0.5)
    assert spinning() == []
    assert stats["ticks"] + stats["missed_ticks"] >= 450 and stats["rate_hz_target"] == 1000.0


def test_unreachable_device_names_its_config_line():
    from rig.errors import RigError
    cfg = config.load("sim-rig")  # nobody serves it here
    cfg.devices["tc"].params["port"] = 1  # nothing listens on port 1
    rig = Rig(cfg, clock=lambda: 0.0)
    rig.drivers = {"tc": rig.drivers["tc"]}
    with pytest.raises(RigError, match=r"^sim-rig.toml:\d+: device 'tc': no Modbus server at 127.0.0.1:1$"):
        rig.open()


def test_a_cell_at_5_khz_streams_and_dates_every_frame_at_5_khz():
    cfg = config.at_rate(config.load("virtual"), 5000.0)
    vr = VirtualRig(cfg, damper="koni")
    cfg = vr.start()
    rig = Rig(cfg, clock=vr.clock)
    rig.open()
    try:
        for _ in range(1000):
            vr.step(1.0 / cfg.rate_hz)
            rig.poll()
        got = rig.drain()
    finally:
        rig.close()
        vr.close()
    assert vr.plant.h == pytest.approx(2e-4)
    for name in ("force", "x", "v"):
        t = got[name][0]
        assert len(t) >= 999 and np.allclose(np.diff(t), 2e-4, atol=1e-6), name


def _fifo_granted():
    from rig.pacing import realtime_priority, restore_priority
    old = realtime_priority(1)
    if old is not None:
        restore_priority(old)
    return old is not None


@pytest.mark.skipif(not _fifo_granted(), reason="this OS grants no SCHED_FIFO here (root or an rtprio limit)")
def test_a_wall_clock_cell_runs_its_threads_above_normal_programs_then_gives_that_back():
    """rig.realtime_priority (50 in virtual.toml): a cell in real time starts its emulators'
    threads under SCHED_FIFO at 1 and paces its loop at 50, an analysis on it runs at normal
    priority; closed, the caller is normal again. A cell on a simulated clock keeps normal
    priority."""
    import os
    import threading

    from protocols import cell
    from rig.pacing import normal_priority
    before = set(os.listdir("/proc/self/task"))
    with cell.embedded("koni", realtime=True) as c:
        started = set(os.listdir("/proc/self/task")) - before
        assert started and all(os.sched_getscheduler(int(t)) == os.SCHED_FIFO for t in started)
        assert os.sched_getscheduler(0) == os.SCHED_FIFO and os.sched_getparam(0).sched_priority == 1
        assert c.pacer().fifo_priority == 50
        with normal_priority():  # an analysis on the cell (discover's, a live worker's)
            seen = []
            t = threading.Thread(target=lambda: seen.append(os.sched_getscheduler(0)))
            t.start()
            t.join()
            assert os.sched_getscheduler(0) == os.SCHED_OTHER and seen == [os.SCHED_OTHER]
        assert os.sched_getscheduler(0) == os.SCHED_FIFO
    assert os.sched_getscheduler(0) == os.SCHED_OTHER
    with cell.embedded("koni") as c:
        assert os.sched_getscheduler(0) == os.SCHED_OTHER and c.pacer().wall_clock is False


@pytest.mark.skipif(not _fifo_granted(), reason="this OS grants no SCHED_FIFO here (root or an rtprio limit)")
def test_a_polled_modules_thread_runs_above_the_cells_other_threads():
    """A real cell's Modbus module is polled on a thread of its own at DEVICE_PRIORITY, above
    the observers' and recorder's threads: a CPU-bound thread at its own priority would never
    yield to it."""
    import os
    import time

    from rig import config as rig_config
    from rig.devices.modbus import ModbusModule
    from rig.pacing import DEVICE_PRIORITY, THREADS_PRIORITY, realtime_priority, restore_priority
    from sim_backend.emulators.modbus_modules import ModbusServers
    cfg = rig_config.load("sim-rig")
    cfg.devices["tc"].params["port"] = "auto"
    servers = ModbusServers(cfg, ["tc"])
    old = realtime_priority(THREADS_PRIORITY)
    module = ModbusModule("tc", cfg.devices["tc"].params, threaded=True)
    try:
        module.open()
        tid = module._thread.native_id
        deadline = time.monotonic() + 5
        while os.sched_getparam(tid).sched_priority != DEVICE_PRIORITY and time.monotonic() < deadline:
            time.sleep(0.01)
        assert os.sched_getscheduler(tid) == os.SCHED_FIFO and os.sched_getparam(tid).sched_priority == DEVICE_PRIORITY
        assert os.sched_getparam(0).sched_priority == THREADS_PRIORITY  # the caller keeps its own
        while not module.poll(None) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert module.frames  # and it reads
    finally:
        module.close()
        servers.close()
        restore_priority(old)


def test_a_stale_channel_names_what_its_device_knows_is_wrong():
    """A Modbus module that stopped answering: whether its request failures or its channels'
    age trips first is a race of a few milliseconds, so the watchdog's sentence carries the
    device's own reason (issue 74's wired fault test lost that race once)."""
    from rig.rig import Reading
    cfg = config.load("virtual")
    safety = Safety(cfg)
    values = {"x": 0.0381, "x_internal": 0.0381, "T_body": 300.0, "T_reservoir": 300.0, "P_gas": 2e6}
    fresh = {name: Reading(1.0, values.get(name, 0.0), None) for name in cfg.channels}
    assert safety.check(fresh, 1.0) is None
    stale = {**fresh, "P_gas": Reading(0.7, 2e6, None)}
    said = safety.check(stale, 1.0, trouble=lambda d: "Modbus request failed 1 time in a row (timed out)"
                        if d == cfg.channels["P_gas"].device else "")
    assert said.startswith("watchdog: P_gas (analog): no new data for 300 ms")
    assert said.endswith("ms): Modbus request failed 1 time in a row (timed out)")
    assert safety.check(stale, 1.0).endswith("(limit 100 ms)")  # a device with nothing to say adds nothing


@pytest.mark.realtime
def test_a_wall_clock_loop_not_granted_fifo_asks_for_the_shortest_slice_then_gives_it_back(cell):
    """Where SCHED_FIFO is not granted (or not asked for), the loop's thread runs on the
    normal policy's shortest slice (rig.pacing.LOOP_SLICE_S), so a busy program beside it
    yields its core when a tick is due; after the run the thread's own slice is back."""
    from rig.pacing import LOOP_SLICE_S, RealTimePacer, _sched_attr
    if _sched_attr() is None:
        pytest.skip("this kernel or architecture has no sched_getattr")
    vr, rig = cell
    before = _sched_attr().runtime
    seen = []

    def plan(t, readings):
        seen.append(_sched_attr().runtime)
        return None if t > 0.05 else MID
    res = ControlLoop(rig, RealTimePacer(rig.config.rate_hz, virtual_rig=vr), Safety(rig.config)).run(plan)
    assert res.fault is None and not res.sched_fifo
    kernel_takes_it = seen[0] != before  # a kernel before EEVDF's slices (6.12) keeps its own
    assert set(seen) == ({round(LOOP_SLICE_S * 1e9)} if kernel_takes_it else {before})
    assert _sched_attr().runtime == before
