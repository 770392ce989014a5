"""`dyno bench log`: sustained samples per second into an MCAP recording (zstd chunks,
JSON batches, the recorder the runs use), against the data rate of the most demanding
protocol on the virtual rig's wiring. Goal: at least 20 times that rate on one core."""
from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np

from rig import config as rig_config
from rig.devices import TRANSPORTS
from protocols.errors import UsageError

from protocols.io.recording import Recorder


def protocol_rate(cfg):
    """Samples per second a protocol records: streamed channels at the loop rate, polled
    ones at their poll rate, plus one setpoint per tick (every protocol streams the same
    channels, so the most demanding is any that runs the loop at full rate)."""
    rate = cfg.rate_hz  # setpoints
    for ch in cfg.channels.values():
        d = cfg.devices[ch.device]
        rate += TRANSPORTS[d.transport].rate_hz(d.params, cfg.rate_hz)
    return rate


def bench_log(seconds=5.0):
    cfg = rig_config.load("virtual")
    need = protocol_rate(cfg)
    per_drain = {n: round(TRANSPORTS[cfg.devices[c.device].transport].rate_hz(cfg.devices[c.device].params,
                                                                               cfg.rate_hz) * 0.1)
                 for n, c in cfg.channels.items()}  # samples a channel gives in one 0.1 s drain
    rng = np.random.default_rng(0)
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "bench.mcap"
        rec = Recorder(path, cfg, "{}", "bench", {})
        n = 0
        t = 0.0
        t0 = time.perf_counter()
        while time.perf_counter() - t0 < seconds:
            batch = {}
            for name, k in per_drain.items():
                ts = t + np.arange(k) * (0.1 / k)
                batch[name] = (ts, 1000.0 * rng.standard_normal(k))
                n += k
            rec.samples(batch)
            rec.setpoints(list(t + np.arange(100) * 1e-3), list(rng.standard_normal(100)))
            n += 100
            t += 0.1
        rec.commit()
        rec.close()
        wall = time.perf_counter() - t0
        size = path.stat().st_size
    rate = n / wall
    return {"samples_per_s": rate, "protocol_samples_per_s": need, "ratio": rate / need, "goal_ratio": 20.0,
            "goal_met": rate / need >= 20.0, "bytes_per_sample": size / n, "seconds": wall}


GOAL_IDENTIFY_S = 120.0


def bench_identify(recording=None, damper="koni", truth=False):
    """Wall time of `dyno identify` on a full standard-sequence recording (recorded first
    on the virtual rig when none is given). Goal: under 2 minutes on the 2-core machine.
    truth: compare with `damper` (the round trip: per-parameter errors, the peak curve)."""
    import json
    import subprocess
    import sys
    dyno = str(Path(sys.executable).parent / "dyno")
    with tempfile.TemporaryDirectory() as tmp:
        if recording is None:
            recording = str(Path(tmp) / "standard.mcap")
            made = subprocess.run([dyno, "run", "standard", "--damper", damper, "--no-identify", "--out", recording],
                                  capture_output=True, text=True)
            if made.returncode:
                last = made.stderr.strip().splitlines()[-1] if made.stderr.strip() else f"exit {made.returncode}"
                raise UsageError(f"bench identify: recording {damper}: {last.removeprefix('dyno: error: ')}")
        t0 = time.perf_counter()
        p = subprocess.run([dyno, "identify", recording, "--json", "--out", str(Path(tmp) / "m.json")]
                           + (["--truth", damper] if truth else []), capture_output=True, text=True)
        wall = time.perf_counter() - t0
    if p.returncode:
        last = p.stderr.strip().splitlines()[-1] if p.stderr.strip() else f"exit {p.returncode}"
        raise UsageError(f"bench identify: {last.removeprefix('dyno: error: ')}")
    doc = json.loads(p.stdout)
    out = {"recording": str(recording), "damper": damper, "wall_s": wall, "goal_wall_s": GOAL_IDENTIFY_S,
           "goal_met": wall < GOAL_IDENTIFY_S, "heldout_nrmse": doc["heldout_nrmse"], "steps": doc["steps"]}
    if truth:
        out["errors"] = {r["name"]: r["rel_error"] for r in doc["parameters"] if r["rel_error"] is not None}
        out["curve_max_rel_error"] = doc["curve"]["max_rel_error"]
        out["curve_max_rel_error_tested"] = doc["curve"]["max_rel_error_tested"]
    return out


def bench_diagnose(seconds=60.0, rate_hz=5000.0):
    """`dyno bench diagnose`: a recording of `seconds` of sine matrix at rate_hz from the
    plain plant (no wires), then the diagnosis's wall time (goal, issue 47: 60 s at 5 kHz in < 3 s)
    and the next test's design within 120 s of rig time on the virtual cell (goal < 10 s)."""
    from models import threads
    from models.diagnose import design, diagnose
    from protocols.discover import limits
    from protocols.proof import offline_recording
    from sim_backend.options import benchmark
    from rig import config as rig_config
    params = {"amplitudes_mm": [12.7, 6.4, 3.2, 1.6], "freqs_hz": [1.0, 2.0, 4.0, 8.0, 16.0],
              "settle_cycles": 1, "record_cycles": 5}
    t0 = time.perf_counter()
    ch, events, _ = offline_recording(benchmark("diagnose"), rate_hz=rate_hz, params=params)
    t_rec = time.perf_counter() - t0
    t_end = ch["force"][0][-1]
    if t_end > seconds:  # cut to `seconds` of recording
        ch = {n: (t[t <= seconds], v[t <= seconds]) for n, (t, v) in ch.items()}
        events = [e for e in events if e.t <= seconds]
    t0 = time.perf_counter()
    res = diagnose(ch, events, jobs=threads.cores())
    wall = time.perf_counter() - t0
    t0 = time.perf_counter()
    props = design.propose(res, limits(rig_config.load("virtual")), 120.0)
    t_design = time.perf_counter() - t0
    return {"recording_s": float(min(t_end, seconds)), "rate_hz": rate_hz, "samples": int(len(ch["force"][0])),
            "make_recording_s": t_rec, "diagnose_s": wall, "accepted": res.accepted, "goal_s": 2.0, "timing": res.timing,
            "design_s": t_design, "design_goal_s": 10.0, "proposals": len(props)}


IMPORT_GOAL_S = 5.0  # s for 1,000,000 rows (issue 43)


IMPORT_REPEATS = 3


def bench_import(rows=1_000_000):
    """Seconds `dyno import` takes for a CSV of `rows` rows (time, displacement, force)
    written with date-time stamps and with plain seconds, end to end (read, convert,
    record, catalogue): the median of IMPORT_REPEATS imports in one process (the first
    also loads the modules), and the slowest."""
    import contextlib
    import io
    from datetime import datetime, timedelta, timezone

    from protocols.app import cli
    t = np.arange(rows) / 1000.0
    x = 30 + 5 * np.sin(2 * np.pi * t)
    F = 100 * np.cos(2 * np.pi * t)
    out = {"rows": rows, "goal_s": IMPORT_GOAL_S}
    with tempfile.TemporaryDirectory() as d:
        plain = Path(d) / "plain.csv"
        np.savetxt(plain, np.column_stack([t, x, F]), delimiter=",", header="t,x,F", comments="", fmt="%.6f")
        start = datetime(2025, 11, 14, 20, 14, 37, tzinfo=timezone.utc)
        stamped = Path(d) / "stamped.csv"
        with open(stamped, "w") as f:
            f.write("time,x,F\n")
            f.writelines(f"{(start + timedelta(milliseconds=i)).isoformat(' ', 'microseconds')[:26]},{a:.6f},{b:.6f}\n"
                         for i, (a, b) in enumerate(zip(x, F)))
        for name, src, time_map in (("seconds", plain, "time=t"), ("date-time stamps", stamped, "time=time")):
            took = []
            for _ in range(IMPORT_REPEATS):  # this machine's speed wanders by a third from run to run
                t0 = time.perf_counter()
                with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
                    code = cli.main(["import", str(src), "--out", str(Path(d) / f"{src.stem}.mcap"), "--overwrite",
                                     "--map", time_map, "--map", "displacement=x:mm", "--map", "force=F:N"])
                if code != 0:
                    raise UsageError(f"bench import: dyno import of the {name} file failed")
                took.append(time.perf_counter() - t0)
            out[name] = float(np.median(took))
            out[f"{name}, slowest"] = max(took)
    out["goal_met"] = all(out[k] < IMPORT_GOAL_S for k in ("seconds", "date-time stamps"))
    return out
