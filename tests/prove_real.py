"""`dyno prove --on` on every shared real recording (issue 72): each file of ../shared/data
imported as real_data.toml says, each catalogue effect and cell fault hidden in copies of it
at --sizes (RMS, % of its force range), and a table per file of what its diagnosis found,
with the smallest size found per effect across files.

    .venv/bin/python -m tests.prove_real [--data ../shared/data] [--sizes 3,5] [--keep runs.jsonl] --markdown > docs/results/prove-on.md
    .venv/bin/python -m tests.prove_real --from runs.jsonl > docs/results/prove-on.md   # from the kept lines
"""
import json
import subprocess
import sys
import tempfile
from pathlib import Path

from tests.real_data import DYNO, _dyno, _said, files, generate

SIZES = "3,5"
ROUNDS = "2"  # each diagnosis's rounds at most: the hidden effect shows in the first two, in half the time


def one(task):
    """{file, untouched, rows, smallest} of prove --on on one imported file, or {file, error}."""
    src, imports = task
    out = {"file": f"{src.parent.name}/{src.name}"}
    with tempfile.TemporaryDirectory() as d:
        rec = Path(d) / "x.mcap"
        p, _ = _dyno(d, "import", src, "--out", rec, *imports)
        if p.returncode != 0:
            return {**out, "error": _said(p, d)}
        p = subprocess.run([DYNO, "prove", "--on", rec, "--sizes", SIZES, "--rounds", ROUNDS, "--json", "--jobs", "1"], cwd=d,
                           capture_output=True, text=True, timeout=7200)
        if p.returncode != 0:
            return {**out, "error": _said(p, d)}
        return {**out, **json.loads(p.stdout)}


def markdown(results):
    import views.reports.markdown as md
    stamp = md.stamp().replace("`dyno ", "`python -m tests.prove_real ")
    done = [r for r in results if "rows" in r]
    hidden = list(dict.fromkeys(row["hidden"] for r in done for row in r["rows"]))
    shown = (lambda s: "-" if s is None else f"{s:g}")
    def cell(r, h):  # the smallest size found; n/a where it cannot be hidden at any size
        rows = [row for row in r["rows"] if row["hidden"] == h]
        if rows and all(row["outcome"] == "cannot hide" for row in rows):
            return "n/a"
        return shown(r["smallest_found"].get(h))
    summary = md.table(("file", "untouched names", *hidden),
                       [(r["file"], ", ".join(r["untouched"]["untouched"]["named"]) or "nothing",
                         *(cell(r, h) for h in hidden)) for r in done])
    found = {h: sum(r["smallest_found"].get(h) is not None for r in done) for h in hidden}
    lines = ["# Effects hidden in real recordings (dyno prove --on)", stamp,
             __doc__.split("\n\n")[0].replace("\n", " "),
             f"Sizes {SIZES} % of each file's force range (RMS); each diagnosis stops after {ROUNDS} rounds. Smallest size found per file ('-': not found at "
             f"these sizes; n/a: it cannot be hidden there at these sizes, a friction effect where the baseline fits "
             f"no friction). Found on how many of {len(done)} files: "
             + ", ".join(f"{h} {n}" for h, n in found.items()) + ".", summary]
    lines += [f"- {r['file']}: {r['error']}" for r in results if "error" in r]
    for r in done:
        rows = [(row["hidden"], f"{row['size']:g}", shown(row["value"]), f"{row['rms_n']:.3g}", row["outcome"],
                 row["said_as"] or "-", shown(row["found_value"]), "yes" if row["also_untouched"] else "")
                for row in r["rows"]]
        nulls = "; ".join(f"{k}: named {', '.join(n['named']) or 'nothing'}, noise {n['noise_sd']:.3g} N"
                          for k, n in r["untouched"].items())
        lines += [f"## {r['file']}", f"Force range {r['force_range_n']:.4g} N; {nulls}.",
                  md.table(("hidden", "size [%]", "value hidden", "RMS [N]", "found", "said as", "value found",
                            "also on the untouched"), rows)]
    return "\n\n".join(lines) + "\n"


KEEP = None  # a file each result is appended to as it ends (--keep)


def kept(task):
    """one(task), appended to KEEP as a JSON line."""
    out = one(task)
    if KEEP:
        with open(KEEP, "a") as f:
            f.write(json.dumps(out) + "\n")
    return out


def main(argv=None):
    """As real_data's generate, each file's result also appended to --keep FILE as it ends
    (a JSON line: a long run that stops keeps what it made), and --from FILE prints the
    Markdown of such lines without running."""
    global SIZES
    argv = list(sys.argv[1:] if argv is None else argv)
    opts = {}
    for flag in ("--sizes", "--keep", "--from"):
        if flag in argv:
            i = argv.index(flag)
            opts[flag] = argv[i + 1]
            del argv[i:i + 2]
    SIZES = opts.get("--sizes", SIZES)
    if "--from" in opts:
        print(markdown([json.loads(line) for line in Path(opts["--from"]).read_text().splitlines() if line]))
        return
    global KEEP
    KEEP = opts.get("--keep")
    # the small files first: a stopped run has the most tables
    generate("python -m tests.prove_real", argv, lambda d: sorted(files(d), key=lambda t: t[0].stat().st_size), kept,
             markdown, "recordings")


if __name__ == "__main__":
    main()
