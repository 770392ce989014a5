"""`dyno bench sim|sweep|log|import|loop|identify|diagnose|hil|cluster|catalogue`: measured numbers, not tests; each
prints text, --json, or --markdown for docs/results."""
from __future__ import annotations

from rig.errors import UsageError

from commands.output import emit
from views.reports import markdown as md


def sim(args):
    from proof.bench.speed import bench
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
    from proof.bench.speed import bench_sweep
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
    from proof.bench.throughput import bench_log
    r = bench_log(args.seconds)
    text = (f"MCAP logging: {r['samples_per_s']:,.0f} samples/s sustained ({r['bytes_per_sample']:.1f} bytes/sample "
            f"on disk), {r['ratio']:.0f}x the {r['protocol_samples_per_s']:,.0f} samples/s a protocol records "
            f"(goal >= {r['goal_ratio']:.0f}x: {'met' if r['goal_met'] else 'NOT met'})")
    return emit(args, "MCAP logging rate (dyno bench log)", r, text)


def import_(args):
    from proof.bench.throughput import bench_import
    r = bench_import(args.rows)
    text = (f"dyno import of {r['rows']:,} CSV rows, median of 3: {r['seconds']:.1f} s with times in seconds, "
            f"{r['date-time stamps']:.1f} s with date-time stamps (slowest {r['seconds, slowest']:.1f} and "
            f"{r['date-time stamps, slowest']:.1f} s; goal < {r['goal_s']:g} s: "
            f"{'met' if r['goal_met'] else 'NOT met'})")
    return emit(args, "CSV import time (dyno bench import)", r, text)


def loop(args):
    from proof.bench.timing import baseline, bench_embedded, bench_loop, busy, goals_met, said
    if args.embedded and args.diagnose:
        raise UsageError("bench loop: --diagnose measures the loop against sim-rig, not --embedded")
    with busy(args.busy):  # the parser bounds rate, seconds and busy
        stats = (bench_embedded(args.rate, args.seconds) if args.embedded
                 else bench_loop(args.rate, args.seconds, diagnose=args.diagnose))
        stats["goals_met"] = goals_met(stats)
        stats["machine_baseline"] = baseline(args.rate, args.seconds)
    stats["busy_programs"] = args.busy
    return emit(args, "Control-loop timing (dyno bench loop)", stats, said(stats, args.embedded, args.seconds))


def identify(args):
    from proof.bench.throughput import bench_identify, identify_said
    dampers = args.damper.split(",")
    if args.recording and len(dampers) > 1:
        raise UsageError("bench identify: one --damper with a RECORDING")
    runs = [bench_identify(args.recording, d, truth=args.truth) for d in dampers]
    return emit(args, "Identification round trip (dyno bench identify)", {"runs": runs},
                *identify_said(runs, args.truth))


def diagnose(args):
    from proof.bench.throughput import diagnose_said
    if args.crank:
        from proof.bench.crank import bench
        r = bench(args.seconds or 100.0, args.rate or 300.0, args.runs)
    else:
        from proof.bench.throughput import bench_diagnose
        r = bench_diagnose(args.seconds or 60.0, args.rate or 5000.0, args.runs)
    title, text, body, note = diagnose_said(r, args.crank)
    return emit(args, title, r, text, body, note)


def discover(args):
    from proof.bench.timing import bench_discover
    r = bench_discover(args.budget)
    text = (f"dyno run discover --budget {r['budget_s']:g} on the embedded plain cell: {r['wall_s']:.0f} s of wall "
            f"time for {r['rig_s']:.0f} s of rig time recorded ({r['added_rig_s']:.0f} s of its own tests): "
            f"{r['wall_over_budget']:.2f} x the budget (goal <= {r['goal_wall_over_budget']:g}: "
            f"{'met' if r['goal_met'] else 'NOT met'}), {r['wall_over_rig']:.2f} x the rig time\n{r['verdict']}")
    return emit(args, "The closed loop's wall time (dyno bench discover)", r, text)


def hil(args):
    from proof.bench.hil import bench, said
    r = bench(args.damper)
    return emit(args, "Hardware-in-the-loop tracking (dyno bench hil)", r, *said(r))


def cluster(args):
    from proof.bench.cluster import bench
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
    from proof.bench.catalogue import bench_catalogue, said
    r = bench_catalogue(args.runs, args.check_recording)
    return emit(args, "Run index at a season's size (dyno bench catalogue)", r, *said(r))
