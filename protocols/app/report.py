"""`dyno report FILE.mcap [OTHER.mcap ...] --out DIR [--model FILE]`: the recording's HTML
report (with the damper model overlaid: --model, or the run's identified
FILE.model.json), or recordings compared with the first."""
from __future__ import annotations

from pathlib import Path

from models.damper import DamperError
from models.minimal import load_reference as load_damper
from protocols.errors import UsageError

from protocols.io.files import existing_files, filled, output_folder
from protocols.reports.comparison import compare
from protocols.reports.recording import report


def _model(args):
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
    out = output_folder(args.out, existing_files(args.file, args.other, args.model), args.overwrite)
    with filled(out) as folder:
        if args.other:
            index, pngs = compare([args.file, *args.other], folder, args.units)
        else:
            model = _model(args)
            if model is not None:
                print(f"model overlaid: {model.name}")
            units = args.units
            try:
                index, pngs = report(args.file, folder, model, _speeds(args.speeds, units), args.paper, units)
            except DamperError as e:  # a model whose effects this recording cannot carry
                raise UsageError(f"--model: {e}") from None
            pngs = [*pngs, Path(folder) / "report.pdf"]
    for p in [*pngs, index]:
        print(out / Path(p).name)
    return 0
