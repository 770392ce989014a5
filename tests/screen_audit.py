"""The screen's audit (issue 90): every recording diagnosed twice, every candidate fitted in
full (`--no-screen`, the screen's values still computed) and as `dyno diagnose` runs (the
candidates the screen rules out not fitted). A candidate the full fit finds worth a
judgement's acceptance (RELEVANCE / BAND noise variances or more) must never be ruled out;
the two must say the same. The shared real recordings (real_data.toml, each with the
default holdout and with the last 15 % held out) and the plant's concealed effects at
their noise floor and nulls (prove's cases, two seeds, 1 kHz, no wires).

    .venv/bin/python -m tests.screen_audit [--data ../shared/data] [--markdown] > docs/results/screen.md
"""
import json
import subprocess
import tempfile
import time
from pathlib import Path

from models.diagnose import screen
from models.diagnose.referees import RELEVANCE
from models.diagnose.stability import BAND
from tests.real_data import DYNO, files, generate

HOLDOUTS = ("interleaved", "tail:0.15")
SEEDS = (0, 1)


def cases(data: Path):
    """The real files with each holdout, then the plant's concealed effects and nulls."""
    from sim_backend.effects import HIDDEN
    from sim_backend.options import plain_cell
    concealed = plain_cell()[2]["concealed"]
    return ([("file", (src, imports, h)) for src, imports in files(data) for h in HOLDOUTS]
            + [("plant", (e, s)) for s in SEEDS for e in [None] + [e for e in HIDDEN if e in concealed]])


def _said(doc):
    """What a diagnosis says: (accepted, named, at the edge), and its candidates."""
    return [doc["accepted"], doc["named"], doc["at_edge"]], [
        (c["round"], c["effect"], c["gain_noise_variances"], c["screen_noise_variances"], c["screened"])
        for c in doc["candidates"]]


def _files(src, imports, holdout):
    docs = []
    with tempfile.TemporaryDirectory() as d:
        rec = Path(d) / "x.mcap"
        p = subprocess.run([DYNO, "import", str(src), "--out", str(rec), *imports], capture_output=True, text=True)
        for flags in (["--no-screen"], []):
            if p.returncode == 0:
                t0 = time.perf_counter()
                p = subprocess.run([DYNO, "diagnose", str(rec), "--json", "--holdout", holdout, *flags],
                                   capture_output=True, text=True)
                docs.append((json.loads(p.stdout), time.perf_counter() - t0) if p.returncode == 0 else None)
        if p.returncode != 0:
            return {"error": (p.stderr.strip().splitlines() or ["?"])[-1]}
    return docs


def _plant(effect, seed):
    from models.diagnose import diagnose
    from proof.on_plant import offline_recording
    from sim_backend.effects import scaled
    from sim_backend.options import plain_cell
    from views.reports.diagnosis import to_json
    ch, ev, _ = offline_recording({effect: scaled(effect, plain_cell()[2]["concealed"][effect], 1.0)} if effect else None, seed=seed)
    docs = []
    for screening in (False, True):
        t0 = time.perf_counter()
        res = diagnose(ch, ev, screening=screening)
        docs.append((json.loads(json.dumps(to_json(res), default=float)), time.perf_counter() - t0))
    return docs


def one(task):
    kind, arg = task
    name = (f"{arg[0].parent.name}/{arg[0].name} ({arg[2]})" if kind == "file"
            else f"plant: {arg[0] or 'null'}, seed {arg[1]}")
    docs = _files(*arg) if kind == "file" else _plant(*arg)
    if isinstance(docs, dict):
        return {"case": name, **docs}
    (full, t_full), (quick, t_quick) = docs
    said_full, cands = _said(full)
    said_quick, quick_cands = _said(quick)
    screened = [c for c in cands if c[3] is not None]
    reach = [c for c in screened if c[2] >= RELEVANCE / BAND]  # worth an acceptance in some judgement
    return {"case": name, "same": said_full == said_quick, "full": said_full, "quick": said_quick,
            "screened": len(screened), "ruled_out": sum(c[3] < screen.BAR for c in screened),
            "wrongly": [f"round {c[0]} {c[1]}: {c[2]:.3f} fitted, {c[3]:.3f} screened" for c in reach if c[3] < screen.BAR],
            "least": min((c[3] / screen.BAR for c in reach), default=None),
            "not_fitted": sum(c[4] for c in quick_cands), "s": (t_full, t_quick)}


def markdown(results):
    import views.reports.markdown as md
    stamp = md.stamp().replace("`dyno ", "`python -m tests.screen_audit ")
    ok = [r for r in results if "error" not in r]
    least = min((r["least"] for r in ok if r["least"] is not None), default=float("nan"))
    full, quick = sum(r["s"][0] for r in ok), sum(r["s"][1] for r in ok)
    lines = ["# The screen's audit", stamp, __doc__.split("\n\n")[0].replace("\n", " "),
             f"- the screen's bar: {screen.BAR:.3f} noise variances (RELEVANCE / BAND / MARGIN = "
             f"{RELEVANCE:g} / {BAND:g} / {screen.MARGIN:g})",
             f"- candidates screened and fitted in full: {sum(r['screened'] for r in ok)}; below the bar: "
             f"{sum(r['ruled_out'] for r in ok)}; of them worth an acceptance when fitted in full: "
             f"{sum(len(r['wrongly']) for r in ok)}",
             f"- of the candidates worth an acceptance, the least screened gain: {least:.1f} times the bar",
             f"- the same accepted, named and at-the-edge effects screened and not: {sum(r['same'] for r in ok)} of {len(ok)}",
             f"- candidates not fitted as `dyno diagnose` runs: {sum(r['not_fitted'] for r in ok)}; diagnosis time "
             f"{quick:.0f} s against {full:.0f} s fitting every one (the sum over the cases, a process each)", ""]
    rows = [(r["case"], "same" if r["same"] else f"differs: {r['full']} / {r['quick']}", r["screened"], r["ruled_out"],
             "; ".join(r["wrongly"]) or "none", "-" if r["least"] is None else f"{r['least']:.1f}",
             f"{r['s'][0]:.0f} / {r['s'][1]:.0f}") if "error" not in r else (r["case"], r["error"], "", "", "", "", "")
            for r in results]
    lines.append(md.table(("case", "verdict screened", "screened", "below the bar", "ruled out wrongly",
                           "least / bar", "time full / screened [s]"), rows))
    return "\n".join(lines) + "\n"


def main(argv=None):
    generate("python -m tests.screen_audit", argv, cases, one, markdown, "recordings")


if __name__ == "__main__":
    main()
