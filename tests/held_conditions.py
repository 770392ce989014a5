"""A model of all the sine conditions but one, at one coil current, against the condition
held aside: how far a model identified on some of another dyno's tests carries to a test
it never saw (the shared UTFSM sine files: five conditions at five currents). Each file is
imported with real_data.toml's map; `dyno identify` makes the model that needs no
description of the other four conditions, and the held-aside condition is read with it:
the force's RMS error along its motion (% of its force range), the check of its velocity
table against the model, and what the check says lies outside what the model was
identified on. Beside it, the held-aside file's own model held out by cycles.

    .venv/bin/python -m tests.held_conditions [--data ../shared/data] [--markdown] > docs/results/held-conditions.md
"""
import json
import re
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from tests.real_data import DYNO, files, generate

NAME = re.compile(r"^(.+Hz)(.+A)\.txt$")  # <amplitude>mm<frequency>Hz<current>A.txt


def _dyno(cwd, *args):
    return subprocess.run([DYNO, *map(str, args)], cwd=cwd, capture_output=True, text=True, timeout=1800)


def _error(model_path, recording):
    """RMS of the model's force less the measured along the recording, % of its force range."""
    from records import source_filter
    from models.diagnose.data import prepare
    from models.minimal import load
    from records.reader import load_recording, merged
    model = load(model_path)
    *target, meta = load_recording(recording)
    smoothing = source_filter.of(meta)
    t, F = model.along(merged(model.source)[:2] if model.effects else None, target, smoothing)
    d = prepare(*target, smoothing=smoothing)
    measured = np.interp(t, d.t, d.F)
    return float(100 * np.sqrt(np.mean((F - measured) ** 2)) / np.ptp(measured))


def one(task):
    """Everything measured on one current: [{row}] per held-aside condition."""
    current, found = task
    rows = []
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        for cond, (src, args) in found.items():
            assert _dyno(d, "import", src, "--out", d / f"{cond}.mcap", *args).returncode == 0
        for held in found:
            rest = [d / f"{c}.mcap" for c in found if c != held]
            p = _dyno(d, "identify", *rest, "--out", d / f"m-{held}.json")
            own = _dyno(d, "identify", d / f"{held}.mcap", "--out", d / f"own-{held}.json", "--json")
            c = _dyno(d, "check", d / f"{held}.mcap", "--against", d / f"m-{held}.json")
            said = [line.strip() for line in c.stdout.splitlines()]
            rows.append({"current": current, "held": held, "codes": [p.returncode, own.returncode, c.returncode],
                         "error": _error(d / f"m-{held}.json", d / f"{held}.mcap") if p.returncode == 0 else None,
                         "own": json.loads(own.stdout)["heldout_nrmse"] * 100 if own.returncode == 0 else None,
                         "trained": json.loads((d / f"m-{held}.json").read_text())["heldout_nrmse"] * 100
                         if p.returncode == 0 else None,
                         "check": next((s for s in said if s.startswith(("PASS", "FAIL"))), c.stderr.strip()[-200:]),
                         "outside": next((s for s in said if s.startswith("outside what")), "")})
    return rows


def tasks(data: Path):
    """[(current, {condition: (file, import arguments)})] of the sine files."""
    by = {}
    for src, args in files(data):
        m = NAME.match(src.name)
        if src.parent.name == "sine" and m:
            by.setdefault(m.group(2), {})[m.group(1)] = (src, args)
    return sorted(by.items())


def markdown(rows):
    import views.reports.markdown as md
    stamp = md.stamp().replace("`dyno ", "`python -m tests.held_conditions ")
    ok = [r for r in rows if r["error"] is not None]
    inside = [r["error"] for r in ok if not r["outside"]]
    out = [r["error"] for r in ok if r["outside"]]
    summary = [f"{len(rows)} held-aside conditions; every command exited 0 (check: 1, a point outside the band) "
               f"except: {', '.join(r['held'] + r['current'] for r in rows if r['codes'][:2] != [0, 0]) or 'none'}.",
               f"inside what the model was identified on: {len(inside)} conditions, RMS error "
               + (f"{min(inside):.1f}-{max(inside):.1f} % (median {np.median(inside):.1f} %)" if inside else "-") + ".",
               f"outside it (said by the check): {len(out)} conditions, RMS error "
               + (f"{min(out):.1f}-{max(out):.1f} % (median {np.median(out):.1f} %)" if out else "-") + ".",
               "each file's own model, held out by cycles: "
               + (f"{min(r['own'] for r in ok):.2f}-{max(r['own'] for r in ok):.2f} %." if ok else "-")]
    header = ("current", "held aside", "model of the other four, held out by cycles", "RMS error on the held-aside "
              "condition [% of its force range]", "its own model, held out by cycles", "check against the model",
              "outside what the model was identified on")
    table = [(r["current"].replace("x", "."), r["held"].replace("x", "."),
              "-" if r["trained"] is None else f"{r['trained']:.2f} %",
              "-" if r["error"] is None else f"{r['error']:.1f} %", "-" if r["own"] is None else f"{r['own']:.2f} %",
              r["check"][:160], r["outside"].split("this run's ")[-1] if r["outside"] else "-") for r in rows]
    return "\n\n".join(["# A model of four test conditions against the fifth", stamp,
                        __doc__.split("\n\n")[0].replace("\n", " "), "\n".join(f"- {s}" for s in summary),
                        md.table(header, table)]) + "\n"


def main(argv=None):
    generate("python -m tests.held_conditions", argv, tasks, one, lambda parts: markdown(sum(parts, [])),
             "UTFSM sine files")


if __name__ == "__main__":
    main()
