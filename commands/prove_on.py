"""`dyno prove --on RECORDING`: the proof on the user's own real recording
(proof/on_files.py); this module parses, calls and prints."""
from __future__ import annotations

import dataclasses
import json
import sys
from pathlib import Path

from rig.errors import UsageError

HEADER = ("hidden", "size [% of range]", "value hidden", "RMS added [N]", "found", "said as", "value found",
          "also on the untouched")


def run(args, say):
    from models.diagnose.data import DiagnoseError
    from protocols import cluster
    from proof.on_files import SIZES, run_on, smallest
    path = Path(args.on)
    if not path.is_file():
        raise UsageError(f"--on {args.on}: no such file")
    names = [n for n in args.effects.split(",") if n] if args.effects else None
    sizes = args.sizes or list(SIZES)
    try:
        with cluster.pool(getattr(args, "cluster", None), args.jobs) as (pool, _):
            rows, nulls, span, stopped = run_on(path, names, sizes, pool, say, args.rounds)
    except (ValueError, DiagnoseError) as e:
        raise UsageError(f"--on {args.on}: {e}") from None
    least = smallest([r for r in rows if r.outcome != "stopped"])
    try:
        _print(args, path, rows, nulls, span, least, sizes)
    finally:
        if stopped:  # what was diagnosed is printed; the rest are rows marked stopped
            print("dyno: stopped by the operator; the copies diagnosed before it are above, the rest marked "
                  "stopped", file=sys.stderr)
    return 130 if stopped else 0


def _print(args, path, rows, nulls, span, least, sizes):
    if args.json:
        print(json.dumps({"recording": str(path), "force_range_n": span, "sizes": sizes,
                          "untouched": {k: {"named": n.named, "noise_sd": n.noise_sd, "timing": n.timing}
                                        for k, n in nulls.items()},
                          "rows": [{k: v for k, v in dataclasses.asdict(r).items() if k != "steps"} for r in rows],
                          "smallest_found": least}, indent=1))
        return
    lines = _text(rows, nulls, span, least, path)
    if getattr(args, "markdown", False):
        from views.reports import markdown as md
        print(md.document(f"Proof on {path.name} (dyno prove --on)", "\n".join(lines[1:]),
                          f"sizes: RMS of what is hidden, in % of the recording's force range ({span:.4g} N); "
                          f"method: docs/diagnosis.md, 'The proof on a real recording'"))
    else:
        print("\n".join(lines))


def _text(rows, nulls, span, least, path):
    from views.reports import markdown as md
    f = (lambda v: "-" if v is None else f"{v:.3g}")
    cells = [(r.hidden, f"{r.size:g}", f(r.value), f"{r.rms_n:.3g}", r.outcome, r.said_as or "-", f(r.found_value),
              "yes" if r.also_untouched else "") for r in rows]
    out = [f"{path}: force range {span:.4g} N"]
    for k, n in nulls.items():
        out.append(f"- {k}: named {', '.join(n.named) or 'nothing'}; force noise {n.noise_sd:.3g} N. {n.timing}")
    out += ["", md.table(HEADER, cells), "", "Smallest size found [% of the force range]:", ""]
    out.append(md.table(("hidden", "smallest found"),
                        [(h, "not found up to the largest size" if s is None else f"{s:g}") for h, s in least.items()]))
    return out
