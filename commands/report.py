"""`dyno report FILE.mcap [OTHER.mcap ...] --out DIR [--model FILE] [--against REF]`: the
recording's test sheet (report.pdf's page 1, sheet.png; the verdict against REF as `dyno
check` gives it) and its report (with the damper model overlaid: --model, or the run's
identified FILE.model.json), or recordings compared with the first."""
from __future__ import annotations

from pathlib import Path

from models.damper import DamperError
from rig.errors import UsageError

from protocols.units import TOLERANCE
from commands.arguments import FOLDER, overwrite, reference, units, writes


def add(sub):
    """The `dyno report` command's arguments."""
    rp = sub.add_parser("report", help="HTML report with plots of a recording, or several compared")
    rp.add_argument("file")
    rp.add_argument("other", nargs="*", help="more recordings: each compared (B, C, ...) with the first (A)")
    rp.add_argument("--model", default=None, help="damper model JSON to overlay (default: FILE.model.json if present)")
    writes(rp, "--out", FOLDER, required=True, help="output directory")
    rp.add_argument("--speeds", default=None, metavar="V,V,...",
                    help="shaft speeds of the velocity table, in --units' velocity unit (default 0.025-0.5 m/s, "
                         "1-20 in/s)")
    rp.add_argument("--paper", choices=("a4", "letter"), default="a4", help="report.pdf's paper (default a4)")
    reference(rp)
    units(rp)
    overwrite(rp, "the report's files in --out")
    rp.set_defaults(command="report")


def _model(args):
    from models.minimal import load_reference as load_damper
    path = args.model or Path(args.file).with_suffix(".model.json")
    if args.model is None and not Path(path).is_file():
        return None
    try:
        return load_damper(str(path))
    except (DamperError, OSError, ValueError) as e:
        raise UsageError(f"--model: {e}") from None


def _speeds(text, units):
    """--speeds: shaft speeds in the unit system's velocity unit, comma-separated; [m/s]."""
    if text is None:
        return None
    unit = units.unit("velocity")
    try:
        speeds = [float(units.to_si("velocity", float(v))) for v in text.split(",")]
    except ValueError:
        raise UsageError(f"--speeds: {text!r} is not a comma-separated list of speeds in {unit}") from None
    if not speeds or not all(0 < v < 20 for v in speeds):
        raise UsageError(f"--speeds: {text!r}: every speed must be above 0 and below "
                       f"{units.show('velocity', 20.0):g} {unit}")
    return sorted(speeds)


def run(args):
    from records.files import existing_files, filled, output_folder
    from views.reports.comparison import compare
    from views.reports.recording import report
    out = output_folder(args.out, existing_files(args.file, args.other, args.model), args.overwrite)
    with filled(out) as folder:
        if args.other:
            index, pngs = compare([args.file, *args.other], folder, args.units, args.against, args.tolerance)
            pngs = [*pngs, Path(folder) / "report.pdf"]
        else:
            model = _model(args)
            if model is not None:
                print(f"model overlaid: {model.name}")
            units = args.units
            check = None
            if args.against:
                from views.reports import qa
                check = qa.said(*qa.checked(args.file, args.against, args.tolerance or TOLERANCE, units), units)
                print(f"sheet's verdict against {check[1]}: {check[0]}")
            try:
                index, pngs = report(args.file, folder, model, _speeds(args.speeds, units), args.paper, units, check)
            except DamperError as e:  # a model whose effects this recording cannot carry
                raise UsageError(f"--model: {e}") from None
            pngs = [*pngs, Path(folder) / "report.pdf"]
    for p in [*pngs, index]:
        print(out / Path(p).name)
    return 0
