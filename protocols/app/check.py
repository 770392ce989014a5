"""`dyno check RUN.mcap --against REF.mcap|MODEL [--tolerance 5%] [--out DIR]`:
production QA of a run against a reference run or a damper model (protocols/reports/qa.py):
a verdict per velocity point and direction with its margin, check.png of the band, and
exit 0 when every point passes, 1 when one fails."""
from __future__ import annotations

from pathlib import Path

from models.damper import DamperError
from models.damper import load as load_damper
from models.recording import segments
from protocols import catalogue
from protocols.io.files import existing_files, input_file, output_folder, filled
from protocols.io.reader import load_recording
from protocols.reports import peaks, qa
from protocols.units import Units, fmt
from rig.errors import RigError


def _rows(path, model=None):
    ch, events, meta = load_recording(path)
    return peaks.peaks(ch, segments(events), damper=peaks.recorded_damper(meta), model=model)


def run(args):
    try:
        tol = qa.parse_tolerance(args.tolerance)
    except ValueError as e:
        raise RigError(str(e)) from None
    units = Units(args.units)
    if Path(args.against).suffix == ".mcap":
        ref_path = input_file(args.against, "--against")
        run_rows, ref_rows, ref_name = _rows(args.recording), _rows(ref_path), ref_path.name
    else:  # a damper model: a preset's name or FILE.json
        try:
            model = load_damper(args.against)
        except (DamperError, OSError, ValueError) as e:
            raise RigError(f"--against: {e}") from None
        run_rows = _rows(args.recording, model)
        ref_rows, ref_name = qa.model_rows(run_rows), f"model {model.name} along this run's motion"
    results = qa.verdicts(run_rows, ref_rows, tol, units=units)
    if not results:
        raise RigError(f"{Path(args.recording).name} and {ref_name}: no shaft speed measured in both "
                       "(the check needs sine segments covering the velocity table's speeds)")
    u, f = units.unit("velocity"), units.unit("force")
    print(f"check {Path(args.recording).name} against {ref_name}, tolerance {tol}:")
    for r in results:
        print(f"  {fmt(units.show('velocity', r.v_m_s), 3):>6} {u} {r.direction:11s} reference "
              f"{fmt(units.show('force', r.reference_N), 4):>7} {f}, measured {fmt(units.show('force', r.measured_N), 4):>7} "
              f"{f}, margin {fmt(units.show('force', r.margin_N), 3):>6} {f}  {'pass' if r.passed else 'FAIL'}")
    failed = [r for r in results if not r.passed]
    if args.out:
        out = output_folder(args.out, existing_files(args.recording, args.against), args.overwrite)
        with filled(out) as folder:
            png = qa.band_figure(results, Path(folder) / "check.png",
                                 f"{Path(args.recording).name} against {ref_name}, ±{tol}", units)
        print(out / png)
    print(f"{'FAIL' if failed else 'PASS'}: {len(results) - len(failed)} of {len(results)} points inside the band")
    print(catalogue.add_check(args.recording, ref_name, tol, results))
    return 1 if failed else 0
