"""`dyno check RUN.mcap --against REF.mcap|MODEL [--tolerance 5%] [--out DIR]`:
production QA of a run against a reference run or a damper model (views/reports/qa.py):
a verdict per velocity point and direction with its margin, check.png of the band, and
exit 0 when every point passes, 1 when one fails."""
from __future__ import annotations

from pathlib import Path

from protocols.units import TOLERANCE
from commands.arguments import FOLDER, overwrite, reference, units, writes


def add(sub):
    """The `dyno check` command's arguments."""
    ck = sub.add_parser("check", help="QA: a run against a reference run or model, within a tolerance band")
    ck.add_argument("recording")
    reference(ck, required=True)
    writes(ck, "--out", FOLDER, default=None, help="folder for check.png, the band and the run's points")
    units(ck)
    overwrite(ck)
    ck.set_defaults(command="check")


def run(args):
    from views import run_index
    from records.files import existing_files, output_folder, filled
    from views.reports import qa
    from protocols.units import fmt
    units = args.units
    checked, tol = qa.checked(args.recording, args.against, args.tolerance or TOLERANCE, units)
    results, ref_name = checked.results, checked.reference
    u, f = units.unit("velocity"), units.unit("force")
    print(f"check {Path(args.recording).name} against {ref_name}, tolerance {tol}:")
    for note in (checked.compensation, checked.unmeasured, checked.repeats):
        if note:
            print(f"  {note}")
    for r in results:
        print(f"  {fmt(units.show('velocity', r.v_m_s), 3):>6} {u} {r.direction:11s} reference "
              f"{fmt(units.show('force', r.reference_N), 4):>7} {f}, measured "
              f"{fmt(units.show('force', r.measured_N), 4):>7} "
              f"{f}, margin {fmt(units.show('force', r.margin_N), 3):>6} {f}  {'pass' if r.passed else 'FAIL'}")
    failed = [r for r in results if not r.passed]
    if args.out:
        out = output_folder(args.out, existing_files(args.recording, args.against), args.overwrite)
        with filled(out) as folder:
            png = qa.band_figure(results, Path(folder) / "check.png",
                                 f"{Path(args.recording).name} against {ref_name}, ±{tol}", units)
        print(out / png)
    print(qa.verdict(len(results), len(failed), failed, units))
    print(run_index.add_check(args.recording, ref_name, tol, results))
    return 1 if failed else 0
