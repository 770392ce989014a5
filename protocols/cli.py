"""The `dyno` command line. Errors in what the user gave us are one line and exit 2."""
from __future__ import annotations

import argparse
import json
import sys

from models.damper import DamperError, load


def _validate(args):
    from models.validation import format_table, rows
    r = rows()
    if args.json:
        print(json.dumps({"rows": r}, indent=2))
    else:
        print(format_table(r))
    return 0


def _plot_damper(args):
    from models.plots import plot_damper
    d = load(args.damper)
    if d.layout == "simplified":
        raise DamperError(f"{d.name}: simplified models have no loops to plot (damping only, eq 6.1/6.2)")
    if not 0 < args.amplitude_mm * 1e-3 <= d.geometry.stroke / 2:
        raise DamperError(f"--amplitude-mm must be in (0, {d.geometry.stroke * 500:.1f}] for {d.name}")
    if any(f <= 0 or f > 100 for f in args.freq):
        raise DamperError("--freq values must be in (0, 100] Hz")
    for p in plot_damper(d, args.out, args.amplitude_mm * 1e-3, tuple(args.freq), args.temp):
        print(p)
    return 0


def _bench_sim(args):
    from models.bench import bench
    result = bench(seconds=args.seconds, ref_seconds=args.ref_seconds)
    if args.json:
        print(json.dumps(result, indent=2))
        return 0
    for name, c in result["cases"].items():
        print(f"{name:10s} real-time factor {c['realtime_factor']:7.0f}x   "
              f"vs solve_ivp Radau {c['speedup_vs_reference']:6.0f}x   "
              f"max force diff {100 * c['max_force_diff_fraction']:.3f} % of peak")
    print("goals (>= 200x real time, >= 10x reference, < 0.5 % force):",
          "met" if result["goals_met"] else "NOT met")
    return 0


def parser():
    p = argparse.ArgumentParser(prog="dyno", description="Damper dyno controller and damper model tools")
    sub = p.add_subparsers(dest="cmd", required=True)
    v = sub.add_parser("validate", help="reproduce the thesis validation table")
    v.add_argument("--json", action="store_true", help="machine-readable {\"rows\": [...]}")
    v.set_defaults(func=_validate)
    pl = sub.add_parser("plot", help="write plots as PNG")
    plsub = pl.add_subparsers(dest="what", required=True)
    pd = plsub.add_parser("damper", help="loops, composite curve, temperature and pressure plots")
    pd.add_argument("damper", help="preset name (koni, mechformance, fox-light, fox-heavy) or FILE.json")
    pd.add_argument("--out", required=True, help="output directory")
    pd.add_argument("--amplitude-mm", type=float, default=12.7, help="sine amplitude (default 12.7)")
    pd.add_argument("--freq", type=float, nargs="+", default=[1, 2, 4, 8, 16], help="frequencies in Hz")
    pd.add_argument("--temp", type=float, default=94.0, help="damper temperature in C (default 94)")
    pd.set_defaults(func=_plot_damper)
    b = sub.add_parser("bench", help="benchmarks (not tests)")
    bsub = b.add_subparsers(dest="what", required=True)
    bs = bsub.add_parser("sim", help="compressible model speed vs a solve_ivp Radau reference")
    bs.add_argument("--json", action="store_true")
    bs.add_argument("--seconds", type=float, default=10.0, help="simulated seconds (default 10)")
    bs.add_argument("--ref-seconds", type=float, default=None,
                    help="simulate only this much with the slow reference (default: all)")
    bs.set_defaults(func=_bench_sim)
    return p


def main(argv=None):
    args = parser().parse_args(argv)
    try:
        return args.func(args)
    except DamperError as e:
        print(f"dyno: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":
    sys.exit(main())
