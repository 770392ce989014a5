"""Real recordings from other machines, end to end as a user runs them (issue 43): each file
of ../shared/data imported with the map its README gives (real_data.toml), then the
report's velocity table, identify's minimal model held out by cycles, the diagnosis with
the last 15 % held out (the split published work uses), and `dyno check` against the
file's own model, each through the `dyno` command and its exit code.

    .venv/bin/python -m tests.real_data [--data ../shared/data] [--markdown] > docs/results/real-data.md
"""
import argparse
import json
import re
import subprocess
import sys
import tempfile
import time
import tomllib
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

HERE = Path(__file__).resolve().parent
DYNO = str(Path(sys.executable).parent / "dyno")
GOAL_NRMSE = 0.05  # identify's held-out error goal on files with periodic motion (issue 43)


def files(data: Path):
    """[(path, import arguments)] of every file real_data.toml names under data."""
    spec = tomllib.loads((HERE / "real_data.toml").read_text())
    out = []
    for entry in spec["file"]:
        args = [a for k in ("map", "gain", "drive") for v in entry.get(k, []) for a in (f"--{k}", v)]
        args += ["--smoothed", entry["smoothed"]] if "smoothed" in entry else []
        out += [(p, args) for p in sorted(data.glob(entry["path"]))]
    return out


def _dyno(cwd, *args):
    t = time.perf_counter()
    p = subprocess.run([DYNO, *map(str, args)], cwd=cwd, capture_output=True, text=True, timeout=1800)
    return p, time.perf_counter() - t


def _velocity_rows(csv_path, most=3):
    """'speed: comp / reb' of the first filled rows of the report's velocity.csv."""
    if not csv_path.is_file():
        return "-"
    rows = [r.split(",") for r in csv_path.read_text().splitlines()[1:]]
    shown = [f"{float(r[0]):g}: {float(r[1]):.0f} / {float(r[2]):.0f}" for r in rows if r[1] and r[2]]
    return "; ".join(shown[:most]) or "-"


def _said(p, d):
    """A command's one-line error, without the temporary folder it ran in."""
    return (p.stderr.strip().splitlines() or [f"exit {p.returncode}"])[-1].replace(f"{d}/", "")


def one(task):
    """Everything measured on one file: {column: text} and the exit codes."""
    src, imports = task
    from records.reader import load_recording
    out = {"file": f"{src.parent.name}/{src.name}"}
    with tempfile.TemporaryDirectory() as d:
        rec = Path(d) / "x.mcap"
        p, s = _dyno(d, "import", src, "--out", rec, *imports)
        out["codes"] = {"import": p.returncode}
        if p.returncode != 0:
            out["import"] = _said(p, d)
            return out
        lines = p.stdout.splitlines()
        ch, _, _ = load_recording(rec, ("force",))
        t = ch["force"][0]
        start = "no date in the file" if "from an unknown date" in lines[0] else \
            "from " + lines[0].split(" from ")[1].split(",")[0]
        out["import"] = f"{len(t)} rows, {1 / float(sorted(t[1:] - t[:-1])[len(t) // 2]):.0f} Hz, {start}, {s:.1f} s"
        out["segments"] = next((ln.removeprefix("segments: ") for ln in lines if ln.startswith("segments:")), "-")
        out["sign"] = next((ln for ln in lines + p.stderr.splitlines() if "sign" in ln and "flip" in ln), "")
        p, _ = _dyno(d, "report", rec, "--out", Path(d) / "rep")
        out["codes"]["report"] = p.returncode
        page = (Path(d) / "rep" / "index.html").read_text() if p.returncode == 0 else ""
        how = "stroke" if "read along the stroke" in page else "peaks"
        out["velocity"] = f"{_velocity_rows(Path(d) / 'rep' / 'velocity.csv')} ({how})"
        p, _ = _dyno(d, "identify", rec, "--json")
        out["codes"]["identify"] = p.returncode
        model = json.loads(p.stdout) if p.returncode == 0 else {}
        if p.returncode != 0:
            out["identify"] = _said(p, d)
        out["nrmse"] = model.get("heldout_nrmse")
        out["undetermined"] = sum("undetermined" in v for v in model.get("parameters", {}).values())
        low = model.get("force_reads_low") or ""
        out["reads_low"] = low.split("reads at least ")[1].split(" low")[0] if "reads at least " in low else ""
        each = [n for r in model.get("repeats_differ", []) for n in r["segments"]]
        for i, name in enumerate(each):  # as identify advises: each repeat alone
            p, _ = _dyno(d, "identify", rec, "--segment", name, "--json", "--out", Path(d) / f"s{i}.json")
            out["codes"][f"identify --segment {name!r}"] = p.returncode
            if p.returncode == 0:
                out.setdefault("each", []).append(json.loads(p.stdout)["heldout_nrmse"])
        p, s = _dyno(d, "diagnose", rec, "--holdout", "tail:0.15", "--json")
        out["codes"]["diagnose"] = p.returncode
        if p.returncode == 0:
            res = json.loads(p.stdout)
            out["diagnosis"] = (f"{100 * res['baseline']['nrmse_heldout']:.2f} → "
                                f"{100 * res['final']['nrmse_heldout']:.2f} %, "
                                f"R² {res['final']['r2_heldout']:.3f}; "
                                + (", ".join(_said_as(e) for e in res["effects"]) or "nothing accepted")
                                + f" ({s:.0f} s)")
            out["smoothed"] = any(q["kind"] == "smoothed" for q in res["quality"])
            out["rivals"] = any(e.get("rivals") for e in res["effects"])
        else:
            out["diagnosis"] = _said(p, d)
        if model:
            p, _ = _dyno(d, "check", rec, "--against", Path(d) / "x.minimal.json")
            out["codes"]["check"] = p.returncode
            out["check"] = (p.stdout.strip().splitlines() or ["-"])[-2 if " indexed in " in p.stdout else -1] \
                if p.returncode in (0, 1) else _said(p, d)
    return out


def _said_as(e):
    """An accepted effect as the diagnosis said it: named, or a group the recording cannot
    tell apart (A or B), or not named (a flexible stand-in explains as much; too small)."""
    if e.get("replaced_by"):
        return f"{e['effect']} (replaced by {e['replaced_by']})"
    if e["rivals"]:
        return " or ".join([e["effect"]] + [r["effect"] for r in e["rivals"]])
    return e["effect"] + (" (not named: a stand-in explains as much)" if e["stand_in"] else
                          " (small, not named)" if e["small"] else "")


def markdown(results):
    import views.reports.markdown as md
    stamp = md.stamp().replace("`dyno ", "`python -m tests.real_data ")
    header = ("file", "import", "segments", "velocity table [mm/s: N comp / N reb]", "identify held out",
              "diagnosis, last 15 % held out: baseline → final", "check against its own model")
    rows = [(r["file"], r["import"] + (f"; {r['sign']}" if r.get("sign") else ""),
             r.get("segments", "-")[:160], r.get("velocity", "-"),
             r.get("identify", "-") if r.get("nrmse") is None else f"{100 * r['nrmse']:.2f} % ({r['undetermined']} undetermined)"
             + (f"; its repeats differ, each alone {100 * min(r['each']):.2f}-{100 * max(r['each']):.2f} %"
                if r.get("each") else ""),
             r.get("diagnosis", "-") + ("; force smoothed by its source" if r.get("smoothed") else ""),
             r.get("check", "-")) for r in results]
    failed = [(r["file"], k, c) for r in results for k, c in r["codes"].items() if c != 0 and not (k == "check" and c == 1)]
    periodic = [r for r in results if re.search(r"\d+ (sines?|triangles?)\b", r.get("segments", "").split(";")[0])]
    met = [r for r in periodic if r.get("nrmse") is not None and max(r.get("each") or [r["nrmse"]]) < GOAL_NRMSE]
    smoothed = [r for r in results if r.get("smoothed")]
    grouped = [r for r in results if r.get("rivals")]
    moved = ", ".join(f"{r['file']} at least {r['reads_low']} low" for r in results if r.get("reads_low"))
    low = [r for r in results if r.get("reads_low")]
    summary = [f"{len(results)} files; every command exited 0 (check: 0 pass, 1 a point outside the band) "
               f"except: {', '.join(f'{f} {k} exit {c}' for f, k, c in failed) or 'none'}.",
               f"identify, held out by cycles: under {100 * GOAL_NRMSE:g} % of the force range on {len(met)} of "
               f"{len(periodic)} files with periodic motion (a file whose repeats differ: each repeat alone)"
               + (f" (missed: {', '.join(r['file'] for r in periodic if r not in met)})" if len(met) < len(periodic) else "")
               + ".",
               f"force smoothed by its source, said by the diagnosis: {len(smoothed)} files "
               f"({', '.join(r['file'] for r in smoothed) or 'none'}).",
               f"a misfit the recording cannot tell between rivals (said as \"A or B\"): {len(grouped)} files "
               f"({', '.join(r['file'] for r in grouped) or 'none'}).",
               f"a force whose zero moved (a gas force fitted below zero: an offset kept or a mean removed), said by "
               f"identify: {len(low)} files ({moved or 'none'})."]
    return "\n\n".join(["# Real recordings from other machines", stamp, __doc__.split("\n\n")[0].replace("\n", " "),
                        "\n".join(f"- {s}" for s in summary), md.table(header, rows)]) + "\n"


def generate(prog, argv, tasks_of, measure, markdown, what):
    """A results generator's run: the tasks tasks_of finds under --data, each measured in a
    pool of --jobs processes, printed as Markdown (--markdown) or a JSON line each."""
    ap = argparse.ArgumentParser(prog=prog)
    ap.add_argument("--data", default=str(HERE.parent.parent / "shared" / "data"))
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--markdown", action="store_true")
    args = ap.parse_args(argv)
    tasks = tasks_of(Path(args.data))
    if not tasks:
        sys.exit(f"{prog}: no {what} under {args.data}")
    with ProcessPoolExecutor(args.jobs) as pool:
        results = list(pool.map(measure, tasks))
    print(markdown(results) if args.markdown else "\n".join(json.dumps(r) for r in results))


def main(argv=None):
    generate("python -m tests.real_data", argv, files, one, markdown, "recordings")


if __name__ == "__main__":
    main()
