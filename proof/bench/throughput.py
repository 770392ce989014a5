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
from rig.errors import UsageError

from records.recorder import Recorder


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


def repeated(diagnosis, runs):
    """(the result of the run of median wall time, {"runs", "diagnose_s" (the median),
    "diagnose_min_s", "diagnose_max_s"}) of `runs` diagnoses of one recording in this
    process: the first is a process's first (the compiled kernels loaded from their cache),
    the later ones share the bootstrap's kept resamples, as a rig's repeated diagnoses do."""
    done = []
    for _ in range(runs):
        t0 = time.perf_counter()
        res = diagnosis()
        done.append((time.perf_counter() - t0, res))
    walls = sorted(w for w, _ in done)
    median = walls[(len(walls) - 1) // 2]
    return next(r for w, r in done if w == median), {"runs": runs, "diagnose_s": median, "diagnose_min_s": walls[0],
                                                      "diagnose_max_s": walls[-1]}


def bench_diagnose(seconds=60.0, rate_hz=5000.0, runs=3):
    """`dyno bench diagnose`: a recording of `seconds` of sine matrix at rate_hz from the
    plain plant (no wires), then the diagnosis's wall time (goal, issue 47: 60 s at 5 kHz in < 3 s)
    and the next test's design within 120 s of rig time on the virtual cell (goal < 10 s)."""
    from workers import threads
    from models.diagnose import design, diagnose
    from protocols.discover import limits
    from proof.on_plant import offline_recording
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
    res, walls = repeated(lambda: diagnose(ch, events, jobs=threads.cores()), runs)
    t0 = time.perf_counter()
    props = design.propose(res, limits(rig_config.load("virtual")), 120.0)
    t_design = time.perf_counter() - t0
    return {"recording_s": float(min(t_end, seconds)), "rate_hz": rate_hz, "samples": int(len(ch["force"][0])),
            "make_recording_s": t_rec, **walls, "accepted": res.accepted, "goal_s": 2.0, "timing": res.timing,
            "design_s": t_design, "design_goal_s": 10.0, "proposals": len(props)}


IMPORT_GOAL_S = 5.0  # s for 1,000,000 rows (issue 43)


IMPORT_REPEATS = 3


def bench_import(rows=1_000_000):
    """Seconds `dyno import`'s work takes for a CSV of `rows` rows (time, displacement,
    force) written with date-time stamps and with plain seconds, end to end (read, convert,
    record, run index; records/importing.py): the median of IMPORT_REPEATS imports in
    one process (the first also loads the modules), and the slowest."""
    from datetime import datetime, timedelta, timezone

    from views import run_index
    from records.files import Claim
    from records.importing import Source, import_file
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
                claim = Claim(Path(d) / f"{src.stem}.mcap", overwrite=True, inputs=[src])
                try:
                    run_index.add(import_file(Source(str(src), [time_map, "displacement=x:mm", "force=F:N"]),
                                              claim).path)
                finally:
                    claim.abandon()
                    claim.release()
                took.append(time.perf_counter() - t0)
            out[name] = float(np.median(took))
            out[f"{name}, slowest"] = max(took)
    out["goal_met"] = all(out[k] < IMPORT_GOAL_S for k in ("seconds", "date-time stamps"))
    return out


ROUND_TRIP = ("P0", "V0", "gas_spring.gamma", "K_voil", "friction at mid-stroke, 20 C")


def identify_said(runs, truth):
    """(text, Markdown table, note) of bench_identify's runs (truth: against the damper run)."""
    from views.reports import markdown as md
    text = "\n".join(f"identify {r['damper']}: {r['wall_s']:.1f} s wall (goal < {r['goal_wall_s']:.0f} s: "
                     f"{'met' if r['goal_met'] else 'NOT met'}), held-out loop NRMSE {100 * r['heldout_nrmse']:.2f} %"
                     + (f", peak curve worst {100 * r['curve_max_rel_error']:.1f} %" if truth else "")
                     for r in runs)
    pct = (lambda v: "-" if v is None else f"{100 * v:+.1f} %")
    header = ["damper", "wall time [s]", "held-out loop NRMSE"] + (
        [*(f"{n} error" for n in ROUND_TRIP), "peak curve worst error 0.02-1 m/s"] if truth else [])
    rows = [[r["damper"], f"{r['wall_s']:.1f}", f"{100 * r['heldout_nrmse']:.2f} %"]
            + ([*(pct(r["errors"].get(n)) for n in ROUND_TRIP), f"{100 * r['curve_max_rel_error']:.1f} %"]
               if truth else []) for r in runs]
    note = ("The standard sequence recorded on the virtual rig, then `dyno identify`"
            + (" --truth: errors against the damper the rig ran." if truth else ".")
            + " Goals: P0, V0, gamma within 3 %, peak curve within 5 %, held-out under 3 %, under 2 min.")
    return text, md.table(header, rows), note


def _spread(r):
    """A diagnosis's time over its runs: median (minimum-maximum)."""
    return f"{r['diagnose_s']:.1f} s median ({r['diagnose_min_s']:.1f}-{r['diagnose_max_s']:.1f} s)"


def diagnose_said(r, crank=False):
    """(title, text, Markdown body, note) of bench_diagnose's or the crank bench's result,
    with the diagnosis's stages."""
    from views.reports import markdown as md
    if crank:
        text = (f"diagnosed {r['recording_s']:.0f} s of a slider-crank at {r['rate_hz']:.0f} Hz ({r['samples']} "
                f"samples per channel, hidden: {', '.join(r['hidden'])}) in {_spread(r)} (goal < "
                f"{r['goal_s']:.0f} s); accepted {r['accepted'] or 'nothing'}, named {r['named'] or 'nothing'}")
        title = "Diagnosis time on a crank dyno's recording (dyno bench diagnose --crank)"
    else:
        text = (f"diagnosed {r['recording_s']:.0f} s at {r['rate_hz']:.0f} Hz ({r['samples']} samples per channel) "
                f"in {_spread(r)} (goal < {r['goal_s']:.0f} s); accepted {r['accepted'] or 'nothing'}; "
                f"next test designed in {r['design_s']:.1f} s (goal < {r['design_goal_s']:.0f} s, "
                f"{r['proposals']} sines)")
        title = "Diagnosis time (dyno bench diagnose)"
    t = r["timing"]
    stages = ", ".join(f"{k} {v:.1f} s" for k, v in t["stages_s"].items())
    text += f"\nby stage: {stages}; {100 * t['cores_used']:.0f} % of {t['cores']} cores busy"
    rows = [[k, f"{v:.2f}", f"{100 * v / max(t['wall_s'], 1e-9):.0f} %"] for k, v in t["stages_s"].items()]
    note = (f"{r['runs']} diagnoses of one recording: {_spread(r)}. The stages are the median run's: wall "
            f"{t['wall_s']:.2f} s; the cores busy: {100 * t['cores_used']:.0f} % of {t['cores']} (CPU time of "
            "the diagnosis and the fits' forked children over wall time times cores).")
    body = (md.table(("quantity", "value"), md.flat({k: v for k, v in r.items() if k != "timing"})) + "\n\n"
            + md.table(["stage", "wall [s]", "share"], rows))
    return title, text, body, note
