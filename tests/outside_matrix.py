"""The second generator's null matrix (issue 29): recordings with no physics beyond a
valve law, a gas spring and sharp Coulomb friction, across what a real cell varies (rate,
noise colour, load-cell filter, force/motion misalignment, valve law, friction), each
diagnosed. A null names no physics; a cell's timing (misalignment, load-cell filter) may be
named only as the timing offset it is, and a valve law other than the baseline's only as
the valve curve's form (neither is said as physics left out).

    .venv/bin/python -m tests.outside_matrix [--seeds N] [--markdown] > docs/results/outside-nulls.md
"""
import argparse
import itertools
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

CELLS = [dict(rate=r, colour=c, loadcell_hz=lc, misalign=m, law=law, friction=fr)
         for r, c, lc, m, (law, fr) in itertools.product(
             (1000.0, 2000.0, 5000.0, 10000.0), ("white", "coloured"), (None, 1000.0), (0.0, 50e-6, -50e-6),
             (("quadratic", 60.0),))]
CELLS += [dict(rate=r, law=law, friction=fr) for r, (law, fr) in itertools.product(
    (1000.0, 5000.0), (("linear", 150.0), ("digressive", 60.0), ("quadratic", 0.0)))]
TIMING = {"sensor_delay"}  # what a misaligned or filtered force channel is, said as a timing offset
FORM = {"valve_form"}  # the baseline's valve law reshaped: not physics


def one(task):
    from models.diagnose import diagnose
    from records.reader import load_recording
    from tests.outside_generator import record
    cell, seed = task
    with tempfile.TemporaryDirectory() as d:
        path = record(Path(d) / "null.mcap", seed=seed, **cell)
        ch, ev, _ = load_recording(path)
    res = diagnose(ch, ev)
    # what is said by name: small findings, rival groups and what a stand-in explains as well are not
    return cell, seed, [s.effect for s in res.steps if s.effect in res.named() or
                        s.effect.split(":")[0] in TIMING | FORM and not s.replaced_by]


def false_named(cell, accepted):
    timing = cell.get("misalign", 0.0) != 0.0 or cell.get("loadcell_hz")
    return [e for e in accepted if not (timing and e in TIMING) and e not in FORM]


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m tests.outside_matrix")
    p.add_argument("--seeds", type=int, default=1)
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--markdown", action="store_true")
    args = p.parse_args(argv)
    tasks = [(c, s) for c in CELLS for s in range(args.seeds)]
    with ProcessPoolExecutor(args.jobs) as ex:
        done = list(ex.map(one, tasks))
    rows, bad = [], 0
    for cell, seed, accepted in done:
        wrong = false_named(cell, accepted)
        bad += bool(wrong)
        rows.append((f"{cell['rate'] / 1e3:g}", cell.get("colour", "white"), cell.get("loadcell_hz") or "-",
                     f"{1e6 * cell.get('misalign', 0.0):+g}", cell["law"], f"{cell['friction']:g}", seed,
                     ", ".join(accepted) or "-", ", ".join(wrong) or "-"))
    from views.reports import markdown as md
    summary = (f"{len(done)} recordings ({len(CELLS)} cells x {args.seeds} seed(s)); physics named that is not "
               f"there in {bad} ({100 * bad / len(done):.0f} %); goal (issue 44): at most 2 %.")
    body = md.table(("kHz", "noise", "load cell Hz", "misalign us", "valves", "friction N", "seed",
                     "said: named, the cell's timing, the valve form", "false physics"), rows)
    if args.markdown:
        stamp = md.stamp().replace("`dyno ", "`python -m tests.outside_matrix ")
        print("\n\n".join(["# The second generator's nulls", stamp, __doc__.split("\n\n")[0].replace("\n", " "),
                           summary, body]) + "\n")
    else:
        print(body + "\n" + summary)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
