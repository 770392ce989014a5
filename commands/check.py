"""`dyno check RUN.mcap --against REF.mcap|MODEL [--tolerance 5%] [--out DIR]`:
production QA of a run against a reference run or a damper model (protocols/reports/qa.py):
a verdict per velocity point and direction with its margin, check.png of the band, and
exit 0 when every point passes, 1 when one fails."""
from __future__ import annotations

from pathlib import Path

from models.damper import DamperError
from rig.errors import UsageError
from commands.arguments import FOLDER, overwrite, units, writes


def add(sub):
    """The `dyno check` command's arguments."""
    ck = sub.add_parser("check", help="QA: a run against a reference run or model, within a tolerance band")
    ck.add_argument("recording")
    ck.add_argument("--against", required=True, metavar="REF.mcap|MODEL|TABLE",
                    help="the reference: another run, a damper model (preset or FILE.json) simulated along "
                         "this run's motion, or a force-velocity table (a spec sheet, another dyno's export, a "
                         "report's velocity.csv; .csv/.txt/.xlsx, units in the column names)")
    ck.add_argument("--tolerance", default="5%",
                    help="the band, with its unit: 5%% of the reference, 50N, 11lbf, or 5%%,50N (the larger)")
    writes(ck, "--out", FOLDER, default=None, help="folder for check.png, the band and the run's points")
    units(ck)
    overwrite(ck)
    ck.set_defaults(command="check")


def run(args):
    from protocols import catalogue
    from records.files import existing_files, input_file, output_folder, filled
    from protocols.reports import qa
    from protocols.units import fmt
    try:
        tol = qa.parse_tolerance(args.tolerance)
    except ValueError as e:
        raise UsageError(str(e)) from None
    units = args.units
    if Path(args.against).suffix.lower() in (".mcap", *qa.TABLES):
        input_file(args.against, "--against")
    try:
        checked = qa.check(args.recording, args.against, tol, units)
    except qa.OtherSign as e:
        raise UsageError(str(e)) from None
    except (DamperError, OSError, ValueError) as e:
        raise UsageError(f"--against: {e}") from None
    results, ref_name = checked.results, checked.reference
    if not results:
        raise UsageError(f"{Path(args.recording).name} and {ref_name}: no shaft speed measured in both: the check "
                       "reads the force at shaft speeds from sine or crank strokes, or from a random input's "
                       "force-velocity scatter, and these share none")
    u, f = units.unit("velocity"), units.unit("force")
    print(f"check {Path(args.recording).name} against {ref_name}, tolerance {tol}:")
    for note in (checked.compensation, checked.unmeasured):
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
    print(catalogue.add_check(args.recording, ref_name, tol, results))
    return 1 if failed else 0
