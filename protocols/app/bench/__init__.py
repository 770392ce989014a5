"""`dyno bench sim|sweep|log|import|loop|identify|diagnose|hil|cluster|catalogue`: measured numbers, not tests; each
prints text, --json, or --markdown for docs/results."""
from __future__ import annotations

from protocols.errors import UsageError

from protocols.app.output import emit
from protocols.reports import markdown as md


def sim(args):
    from protocols.app.bench.speed import bench
    result = bench(seconds=args.seconds, ref_seconds=args.ref_seconds)
    goals = "goals (>= 200x real time, >= 10x reference, < 0.5 % force): " + ("met" if result["goals_met"] else "NOT met")
    lines = [f"{name:10s} real-time factor {c['realtime_factor']:7.0f}x   "
             f"vs solve_ivp Radau {c['speedup_vs_reference']:6.0f}x   "
             f"max force diff {100 * c['max_force_diff_fraction']:.3f} % of peak" for name, c in result["cases"].items()]
    body = md.table(("damper", "real-time factor", "vs solve_ivp Radau", "max force difference"),
                    [(n, f"{c['realtime_factor']:.0f}x", f"{c['speedup_vs_reference']:.0f}x faster",
                      f"{100 * c['max_force_diff_fraction']:.2f} % of peak") for n, c in result["cases"].items()])
    return emit(args, "Damper model speed (dyno bench sim)", result, "\n".join(lines + [goals]), body,
                 f"{args.seconds:g} s simulated per damper, 12.7 mm at 16 Hz, output every 0.1 ms; {goals}.")


def sweep(args):
    from protocols.app.bench.speed import bench_sweep
    result = bench_sweep(workers=args.workers, spec=args.cluster)
    text = (f"{result['damper']} sweep, {result['points']} points ({len(result['amplitudes_m'])} amplitudes x "
            f"{len(result['freqs_hz'])} frequencies, {result['simulated_s']:.0f} s simulated) on "
            f"{result['workers']} workers: {result['wall_s']:.1f} s wall "
            f"(goal < {result['goal_wall_s']:.0f} s: {'met' if result['goal_met'] else 'NOT met'})")
    f = result["freqs_hz"]
    body = md.table(("damper", "points", "amplitudes [mm]", "frequencies [Hz]", "simulated [s]", "workers", "wall [s]"),
                    [(result["damper"], result["points"], ", ".join(f"{1e3 * a:g}" for a in result["amplitudes_m"]),
                      f"{len(f)} from {f[0]:g} to {f[-1]:g}", f"{result['simulated_s']:.0f}", result["workers"],
                      f"{result['wall_s']:.1f}")])
    return emit(args, "Quarter-car sweep time (dyno bench sweep)", result, text, body,
                f"Goal: under {result['goal_wall_s']:.0f} s: {'met' if result['goal_met'] else 'NOT met'}.")


def log(args):
    from protocols.app.bench.throughput import bench_log
    r = bench_log(args.seconds)
    text = (f"MCAP logging: {r['samples_per_s']:,.0f} samples/s sustained ({r['bytes_per_sample']:.1f} bytes/sample "
            f"on disk), {r['ratio']:.0f}x the {r['protocol_samples_per_s']:,.0f} samples/s a protocol records "
            f"(goal >= {r['goal_ratio']:.0f}x: {'met' if r['goal_met'] else 'NOT met'})")
    return emit(args, "MCAP logging rate (dyno bench log)", r, text)


def import_(args):
    from protocols.app.bench.throughput import bench_import
    r = bench_import(args.rows)
    text = (f"dyno import of {r['rows']:,} CSV rows, median of 3: {r['seconds']:.1f} s with times in seconds, "
            f"{r['date-time stamps']:.1f} s with date-time stamps (slowest {r['seconds, slowest']:.1f} and "
            f"{r['date-time stamps, slowest']:.1f} s; goal < {r['goal_s']:g} s: "
            f"{'met' if r['goal_met'] else 'NOT met'})")
    return emit(args, "CSV import time (dyno bench import)", r, text)


def loop(args):
    from protocols.app.bench.timing import baseline, bench_embedded, bench_loop, busy, goals_met
    if args.embedded and args.diagnose:
        raise UsageError("bench loop: --diagnose measures the loop against sim-rig, not --embedded")
    with busy(args.busy):  # the parser bounds rate, seconds and busy
        stats = (bench_embedded(args.rate, args.seconds) if args.embedded
                 else bench_loop(args.rate, args.seconds, diagnose=args.diagnose))
        stats["goals_met"] = goals_met(stats)
        stats["machine_baseline"] = baseline(args.rate, args.seconds)
    stats["busy_programs"] = args.busy
    j, b = stats["jitter_us"], stats["machine_baseline"]
    against = "the embedded virtual rig" if args.embedded else "sim-rig"
    beside = f", {args.busy} busy program{'s' * (args.busy != 1)} beside" if args.busy else ""
    lines = [f"loop at {stats['rate_hz_target']:g} Hz for {args.seconds:g} s against {against}{beside}: achieved "
             f"{stats['rate_hz']:.1f} Hz, jitter p50 {j['p50']:.0f} us, p99 {j['p99']:.0f} us, p99.9 {j['p999']:.0f} us, "
             f"overruns {stats['overruns']} of {stats['ticks']} ticks, {stats['missed_ticks']} skipped"
             + (f", FAULT: {stats['fault']}" if stats["fault"] else ""),
             f"machine baseline (a bare sleep loop, same rate and duration, no rig): {b['late_beyond_period']} of "
             f"{b['ticks']} ticks late by more than a period, worst {b['max_late_us']:.0f} us"]
    if args.diagnose:
        lines.append(f"live diagnosis alongside, beside the controller: {stats['live_diagnoses']} diagnoses of a 4 Hz "
                     f"segment, median {stats['live_diagnosis_s.median']:.2f} s, worst "
                     f"{stats['live_diagnosis_s.max']:.2f} s each" if stats["live_diagnoses"]
                     else "live diagnosis alongside: none finished")
    if stats["goals_met"] is not None:
        lines.append("goals: " + ("met" if stats["goals_met"] else "NOT met"))
    return emit(args, "Control-loop timing (dyno bench loop)", stats, "\n".join(lines))


ROUND_TRIP = ("P0", "V0", "gas_spring.gamma", "K_voil", "friction at mid-stroke, 20 C")


def identify(args):
    from protocols.app.bench.throughput import bench_identify
    dampers = args.damper.split(",")
    if args.recording and len(dampers) > 1:
        raise UsageError("bench identify: one --damper with a RECORDING")
    runs = [bench_identify(args.recording, d, truth=args.truth) for d in dampers]
    text = "\n".join(f"identify {r['damper']}: {r['wall_s']:.1f} s wall (goal < {r['goal_wall_s']:.0f} s: "
                     f"{'met' if r['goal_met'] else 'NOT met'}), held-out loop NRMSE {100 * r['heldout_nrmse']:.2f} %"
                     + (f", peak curve worst {100 * r['curve_max_rel_error']:.1f} %" if args.truth else "")
                     for r in runs)
    pct = (lambda v: "-" if v is None else f"{100 * v:+.1f} %")
    header = ["damper", "wall time [s]", "held-out loop NRMSE"] + (
        [*(f"{n} error" for n in ROUND_TRIP), "peak curve worst error 0.02-1 m/s"] if args.truth else [])
    rows = [[r["damper"], f"{r['wall_s']:.1f}", f"{100 * r['heldout_nrmse']:.2f} %"]
            + ([*(pct(r["errors"].get(n)) for n in ROUND_TRIP), f"{100 * r['curve_max_rel_error']:.1f} %"]
               if args.truth else []) for r in runs]
    note = ("The standard sequence recorded on the virtual rig, then `dyno identify`"
            + (" --truth: errors against the damper the rig ran." if args.truth else ".")
            + " Goals: P0, V0, gamma within 3 %, peak curve within 5 %, held-out under 3 %, under 2 min.")
    return emit(args, "Identification round trip (dyno bench identify)", {"runs": runs}, text,
                 md.table(header, rows), note)


def diagnose(args):
    if args.crank:
        from protocols.app.bench.crank import bench
        r = bench(args.seconds or 100.0, args.rate or 300.0)
        text = (f"diagnosed {r['recording_s']:.0f} s of a slider-crank at {r['rate_hz']:.0f} Hz ({r['samples']} "
                f"samples per channel, hidden: {', '.join(r['hidden'])}) in {r['diagnose_s']:.1f} s (goal < "
                f"{r['goal_s']:.0f} s); accepted {r['accepted'] or 'nothing'}, named {r['named'] or 'nothing'}")
        title = "Diagnosis time on a crank dyno's recording (dyno bench diagnose --crank)"
    else:
        from protocols.app.bench.throughput import bench_diagnose
        r = bench_diagnose(args.seconds or 60.0, args.rate or 5000.0)
        text = (f"diagnosed {r['recording_s']:.0f} s at {r['rate_hz']:.0f} Hz ({r['samples']} samples per channel) "
                f"in {r['diagnose_s']:.1f} s (goal < {r['goal_s']:.0f} s); accepted {r['accepted'] or 'nothing'}; "
                f"next test designed in {r['design_s']:.1f} s (goal < {r['design_goal_s']:.0f} s, "
                f"{r['proposals']} sines)")
        title = "Diagnosis time (dyno bench diagnose)"
    t = r["timing"]
    stages = ", ".join(f"{k} {v:.1f} s" for k, v in t["stages_s"].items())
    text += f"\nby stage: {stages}; {100 * t['cores_used']:.0f} % of {t['cores']} cores busy"
    rows = [[k, f"{v:.2f}", f"{100 * v / max(t['wall_s'], 1e-9):.0f} %"] for k, v in t["stages_s"].items()]
    note = (f"Wall {t['wall_s']:.2f} s; the cores busy: {100 * t['cores_used']:.0f} % of {t['cores']} (CPU time of "
            "the diagnosis and the fits' forked children over wall time times cores).")
    body = (md.table(("quantity", "value"), md.flat({k: v for k, v in r.items() if k != "timing"})) + "\n\n"
            + md.table(["stage", "wall [s]", "share"], rows))
    return emit(args, title, r, text, body, note)


def discover(args):
    from protocols.app.bench.timing import bench_discover
    r = bench_discover(args.budget)
    text = (f"dyno run discover --budget {r['budget_s']:g} on the embedded plain cell: {r['wall_s']:.0f} s of wall "
            f"time for {r['rig_s']:.0f} s of rig time recorded ({r['added_rig_s']:.0f} s of its own tests): "
            f"{r['wall_over_budget']:.2f} x the budget (goal <= {r['goal_wall_over_budget']:g}: "
            f"{'met' if r['goal_met'] else 'NOT met'}), {r['wall_over_rig']:.2f} x the rig time\n{r['verdict']}")
    return emit(args, "The closed loop's wall time (dyno bench discover)", r, text)


def hil(args):
    from protocols.app.bench.hil import GOALS, bench, pct
    r = bench(args.damper)
    head = ("damper model", "road", "compensator", "J2", "delay [ms]", "residual delay [ms]", "body acc NRMSE", "travel NRMSE",
            "tire load NRMSE", "stopped by")
    rows = [(x["damper"], x["road"], x["compensator"], pct(x.get("j2")), f"{x.get('delay_ms', float('nan')):.2f}",
             f"{x.get('residual_delay_ms', float('nan')):+.2f}", pct(x.get("body_acc_nrmse")),
             pct(x.get("travel_nrmse")), pct(x.get("tire_load_nrmse")), x["fault"] or "-") for x in r["rows"]]
    cost = ", ".join(f"{c} {us:.1f} us" for c, us in r["tick_us"].items())
    goals = (f"best J2 <= {100 * GOALS['j2']:.0f} % on every road: "
             f"{'met' if r['goals']['j2_best_le_2pct'] else 'NOT met'}; "
             f"responses within {100 * GOALS['responses']:.0f} % of the reference: "
             f"{'met' if r['goals']['responses_le_3pct'] else 'NOT met'}; car step and compensator under "
             f"{GOALS['tick_us']:.0f} us a tick: {'met' if r['goals']['tick_le_50us'] else 'NOT met'}; replay within "
             f"{100 * GOALS['replay']:.0f} % in at most 5 iterations: "
             f"{'met' if r['goals']['replay_le_1pct_in_5'] else 'NOT met'}")
    rp = r["replay"]
    replayed = (f"replay of the race car's damper travel on {rp['road']}: NRMS error by iteration "
                + ", ".join(f"{100 * v:.2f} %" for v in rp["nrmse"]) + (f" (stopped: {rp['fault']})" if rp["fault"] else ""))
    text = "\n".join(["  ".join(f"{c[:40]:>12s}" for c in row) for row in [head, *rows]]
                     + [f"per tick (car step + compensator): {cost}", replayed, goals])
    note = (f"On the embedded virtual rig (wire emulators, simulated clock) at 1 kHz, the race-car quarter car (eqs "
            f"5.12-5.14); the "
            f"reference is the same car, road and damper model in simulation. The preset's friction is eq 3.3's "
            f"Coulomb law, the virtual plant's seal has pre-sliding travel: that difference is physics the preset "
            f"leaves out, which is what a hardware-in-the-loop run shows; the goals are judged on the model with "
            f"the plant's friction form, where what is left is the loop's. Per tick: {cost}. {replayed[0].upper()}"
            f"{replayed[1:]}. Goals: {goals}.")
    return emit(args, "Hardware-in-the-loop tracking (dyno bench hil)", r, text, md.table(head, rows), note)


def cluster(args):
    from protocols.app.bench.cluster import bench
    r = bench(args.workers, args.prove_tasks, args.sweep_tasks)
    head = ("work", "tasks", "workers", "task [s]", "serial [s]", "cluster [s]", "start-up [s]", "speed-up",
            "efficiency", "overhead per task [s]", "identical")
    rows = [(x["name"], x["tasks"], x["workers"], f"{x['task_s']:.2f}", f"{x['serial_s']:.1f}",
             f"{x['cluster_s']:.1f}", f"{x['startup_s']:.1f}", f"{x['speedup']:.2f}x", f"{100 * x['efficiency']:.0f} %",
             f"{x['overhead_per_task_s']:+.3f}", "yes" if x["identical"] else "NO") for x in r["rows"]]
    text = "\n".join("  ".join(f"{str(c):>12s}" for c in row) for row in [head, *rows])
    note = ("Serial: one worker in this process; cluster: a Dask LocalCluster of worker processes on 127.0.0.1, "
            "timed from the first submission to the last result (its start-up, with each worker compiling the "
            "kernels once as it joins, apart). Overhead per task = (cluster time x workers - serial time) / tasks. "
            "Goals: >= 1.8x with 2 workers; overhead < 5 % of a task of 2 s or more (docs/cluster.md).")
    return emit(args, "Fan-out on Dask distributed (dyno bench cluster)", r, text, md.table(head, rows), note)


def catalogue(args):
    from protocols.app.bench.catalogue import GOALS, bench_catalogue
    r = bench_catalogue(args.runs, args.check_recording)
    met = r["goals_met"]
    rows = [("index every recording (cold)", f"{r['index_s']:.1f} s", f"< {GOALS['index_s']:g} s", met["index_s"]),
            ("index again, nothing new", f"{r['reindex_s']:.2f} s", f"< {GOALS['reindex_s']:g} s", met["reindex_s"]),
            ("filtered list (serial and since)", f"{r['list_ms']:.2f} ms", f"< {GOALS['list_ms']:g} ms",
             met["list_ms"]),
            ("filtered list (--where on two fields)", f"{r['where_ms']:.2f} ms", "", None),
            ("runs page, every run (at the server)", f"{r['page_s']:.2f} s", f"< {GOALS['page_s']:g} s",
             met["page_s"]),
            ("runs page, every run (in Chromium, to its load event)",
             "not measured (no Playwright or Chromium)" if r["browser_s"] is None else f"{r['browser_s']:.2f} s",
             f"< {GOALS['browser_s']:g} s", met.get("browser_s")),
            ("dyno check, standard recording", f"{r['check_s']:.1f} s", f"< {GOALS['check_s']:g} s", met["check_s"])]
    table = [(what, value, goal, "" if ok is None else "met" if ok else "NOT met") for what, value, goal, ok in rows]
    text = (f"{r['runs']} recordings ({r['mb']:.0f} MB, {r['failed']} unreadable); "
            + "; ".join(f"{w}: {v}" for w, v, _, _ in table))
    note = (f"{r['runs']} recordings of {r['mb'] / r['runs']:.1f} MB each, made from four short sine matrices on "
            f"the direct cell (protocols/app/bench/catalogue.py); the filtered list returned {r['listed']} runs; "
            f"the runs page is {r['page_kb']:.0f} kB of HTML; the check reads both recordings, draws its band and "
            f"adds its row to the catalogue.")
    return emit(args, "Run catalogue at a season's size (dyno bench catalogue)", r, text,
                md.table(("measure", "measured", "goal", ""), table), note)
