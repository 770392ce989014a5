"""`dyno bench loop`: the control loop in real time against `dyno sim-rig` in a separate
process, over the real transports (socketcand CAN, pty serial, Modbus TCP on loopback); or
the embedded virtual rig in real time (`dyno run --realtime`), loop and emulators in one
process. Either beside busy programs, if asked: a cell's computer that does other work."""
from __future__ import annotations

import signal
import subprocess
import sys
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from records.events import RunEnd, DiscoveryVerdict
from rig import config
from rig.errors import RigError
from rig.loop import ControlLoop
from rig.pacing import RealTimePacer
from rig.rig import Rig
from rig.safety import Safety

GOALS = {1000: {"p99_us": 250.0, "overrun_fraction": 0.001}, 500: {"overruns": 0}}


def bench_loop(rate_hz=1000.0, seconds=30.0, damper="koni", diagnose=False):
    """Loop timing stats; diagnose: with the live diagnosis's worker diagnosing a sine
    segment after another all along (its load on the machine, where _pin puts it), and the
    time each of its diagnoses took."""
    from sim_backend.virtual_rig import sim_rig_config
    folder = tempfile.mkdtemp(prefix="dyno-bench-")
    cfg_path = sim_rig_config(folder, rate_hz=rate_hz)
    dyno = str(Path(sys.executable).parent / "dyno")
    load = _diagnosis_load(Path(folder), dyno, damper) if diagnose else None
    proc = subprocess.Popen([dyno, "sim-rig", "--config", str(cfg_path), "--damper", damper,
                             "--seconds", str(seconds + 60)], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True)
    pinned = _pin(proc.pid, load[0].pid if load else None)
    try:
        t0 = time.monotonic()
        while True:
            line = proc.stdout.readline()
            if "serving" in line:
                break
            if not line or time.monotonic() - t0 > 120:
                raise RigError("bench loop: sim-rig did not start")
        cfg = config.load(cfg_path)
        rig = Rig(cfg)
        rig.open()
        try:
            loop = ControlLoop(rig, RealTimePacer(rate_hz, fifo_priority=50), Safety(cfg))
            res = loop.run(_sine(cfg, seconds))
        finally:
            rig.close()
    finally:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
        took = _stop_load(load) if load else None
    out = res.stats(rate_hz)
    out["fault"] = res.fault
    out["cpu_pinning"] = pinned
    if took is not None:
        out["live_diagnoses"] = len(took)
        out["live_diagnosis_s.median"] = float(np.median(took)) if took else None
        out["live_diagnosis_s.max"] = float(np.max(took)) if took else None
    return out


def bench_embedded(rate_hz=1000.0, seconds=30.0, damper="koni"):
    """Loop timing stats of the embedded virtual rig in real time, at the shipped virtual
    cell's real-time priority."""
    from protocols import cell
    from rig import config as rig_config
    with cell.embedded(damper, rig_config.at_rate(rig_config.load("virtual"), rate_hz), realtime=True) as c:
        res = ControlLoop(c.rig, c.pacer(), c.safety()).run(_sine(c.config, seconds))
    out = res.stats(rate_hz)
    out["fault"] = res.fault
    return out


def _sine(config, seconds):
    """The benches' plan: a 5 mm, 2 Hz sine about mid-stroke for `seconds`."""
    mid = (config.limits["x_min"] + config.limits["x_max"]) / 2
    return lambda t, r: None if t >= seconds else mid + 0.005 * np.sin(2 * np.pi * 2 * t)


@contextmanager
def busy(n):
    """n programs that keep a core busy each (at normal priority) while the block runs."""
    spin = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(n)]
    try:
        yield
    finally:
        for p in spin:
            p.kill()
            p.wait()


def _diagnosis_load(folder, dyno, damper):
    """(process, queue of seconds per diagnosis, stop): the live diagnosis's worker function
    on a recorded 4 Hz sine segment of the embedded rig, over and over until stopped, at the
    worker's priority."""
    import multiprocessing as mp

    from protocols.segment_feed import NICE, niced
    rec = folder / "segment.mcap"
    subprocess.run([dyno, "run", "sine-matrix", "amplitudes_mm=12.7", "freqs_hz=4", "--plain", "--damper", damper,
                    "--out", str(rec)], capture_output=True, check=True)
    ctx = mp.get_context("spawn")
    took, stop = ctx.Queue(), ctx.Event()
    p = ctx.Process(target=niced, args=(NICE, _diagnose_again, str(rec), took, stop), daemon=True)
    p.start()
    return p, took, stop


def _diagnose_again(path, took, stop):
    from records.data import segments
    from records.reader import load_recording
    from protocols.live_diagnose import diagnosed
    from views.reports.peaks import recorded_damper
    channels, events, meta = load_recording(path)
    damper = recorded_damper(meta)
    name, _, t0, t1 = segments(events, kinds=("sine",))[0]
    while not stop.is_set():
        start = time.perf_counter()
        diagnosed(damper, channels, events, name, t0, t1)
        took.put(time.perf_counter() - start)


def _stop_load(load):
    p, took, stop = load
    stop.set()
    p.join(timeout=60)
    if p.is_alive():
        p.terminate()
    out = []
    while not took.empty():
        out.append(took.get())
    return out


def _pin(sim_pid, worker_pid=None):
    """Controller on one core, sim-rig on the other, as two machines would be; the live
    diagnosis's worker, if any, beside the controller, whose FIFO loop preempts it at once
    (beside sim-rig it delays the simulator's replies, which a real cell does not have);
    returns whether it could."""
    import os
    cores = sorted(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else []
    if len(cores) < 2:
        return False
    try:
        os.sched_setaffinity(sim_pid, {cores[-1]})
        os.sched_setaffinity(0, set(cores[:-1]))
        if worker_pid is not None:
            os.sched_setaffinity(worker_pid, set(cores[:-1]))
    except OSError:
        return False
    return True


def baseline(rate_hz, seconds):
    """The machine alone: a bare sleep loop at the same rate and priority, no rig. Its
    late ticks are stalls of the OS or hypervisor that no controller code can avoid."""
    from rig.pacing import realtime_priority
    policy = realtime_priority(50)
    import os
    try:
        dt = 1.0 / rate_hz
        t0 = time.perf_counter()
        late = []
        for k in range(1, int(seconds * rate_hz) + 1):
            deadline = t0 + k * dt
            while (left := deadline - time.perf_counter()) > 0:
                if left > 1e-4:
                    time.sleep(left - 1e-4)
            late.append(time.perf_counter() - deadline)
    finally:
        if policy is not None:
            os.sched_setscheduler(0, *policy)
    late = np.array(late)
    return {"ticks": len(late), "late_beyond_period": int(np.sum(late > dt)),
            "max_late_us": float(late.max() * 1e6), "p99_us": float(np.percentile(late, 99) * 1e6)}


def goals_met(stats):
    g = GOALS.get(int(stats["rate_hz_target"]))
    if g is None or stats["fault"]:
        return None if g is None else False
    if "p99_us" in g:
        return stats["jitter_us"]["p99"] < g["p99_us"] and stats["overruns"] < g["overrun_fraction"] * stats["ticks"]
    return stats["overruns"] <= g["overruns"]


DISCOVER_GOAL = 1.2  # wall time over the budget


def bench_discover(budget_s=60.0):
    """`dyno run discover --budget` on the embedded plain cell: its wall time against the
    rig time it recorded (the opening and its own tests) and against its budget; the goal
    (issue 73, 1.5 in issue 47): the wall time at most DISCOVER_GOAL times the budget, on a
    loaded machine too."""
    from records.reader import load_recording
    dyno = str(Path(sys.executable).parent / "dyno")
    with tempfile.TemporaryDirectory(prefix="dyno-bench-") as d:
        out = Path(d) / "discover.mcap"
        t0 = time.monotonic()
        p = subprocess.run([dyno, "run", "discover", "--plain", "--budget", f"{budget_s:g}", "--out", str(out)],
                           capture_output=True, text=True, cwd=d)
        wall = time.monotonic() - t0
        if p.returncode != 0:
            raise RigError(f"bench discover: the run failed: {p.stderr.strip().splitlines()[-1]}")
        channels, events, _ = load_recording(out)
    ends = [e for e in events if isinstance(e, RunEnd) and e.segment == "discover"]
    added = float(ends[-1].params.get("added_s", 0.0)) if ends else 0.0
    rig = float(channels["force"][0][-1] - channels["force"][0][0])
    return {"budget_s": budget_s, "wall_s": wall, "rig_s": rig, "added_rig_s": added,
            "wall_over_budget": wall / budget_s, "wall_over_rig": wall / rig, "goal_wall_over_budget": DISCOVER_GOAL,
            "goal_met": wall <= DISCOVER_GOAL * budget_s,
            "verdict": next((e.message for e in events if isinstance(e, DiscoveryVerdict)), "")}


def said(stats, embedded, seconds) -> str:
    """What `dyno bench loop` says of bench_loop's or bench_embedded's stats."""
    j, b = stats["jitter_us"], stats["machine_baseline"]
    against = "the embedded virtual rig" if embedded else "sim-rig"
    n_busy = stats["busy_programs"]
    beside = f", {n_busy} busy program{'s' * (n_busy != 1)} beside" if n_busy else ""
    lines = [f"loop at {stats['rate_hz_target']:g} Hz for {seconds:g} s against {against}{beside}: achieved "
             f"{stats['rate_hz']:.1f} Hz, jitter p50 {j['p50']:.0f} us, p99 {j['p99']:.0f} us, p99.9 {j['p999']:.0f} us, "
             f"overruns {stats['overruns']} of {stats['ticks']} ticks, {stats['missed_ticks']} skipped"
             + (f", FAULT: {stats['fault']}" if stats["fault"] else ""),
             f"machine baseline (a bare sleep loop, same rate and duration, no rig): {b['late_beyond_period']} of "
             f"{b['ticks']} ticks late by more than a period, worst {b['max_late_us']:.0f} us"]
    if "live_diagnoses" in stats:
        lines.append(f"live diagnosis alongside, beside the controller: {stats['live_diagnoses']} diagnoses of a 4 Hz "
                     f"segment, median {stats['live_diagnosis_s.median']:.2f} s, worst "
                     f"{stats['live_diagnosis_s.max']:.2f} s each" if stats["live_diagnoses"]
                     else "live diagnosis alongside: none finished")
    if stats["goals_met"] is not None:
        lines.append("goals: " + ("met" if stats["goals_met"] else "NOT met"))
    return "\n".join(lines)
