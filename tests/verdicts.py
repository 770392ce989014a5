"""One verdict per recording (issue 71): each shared real recording (../shared/data, imported
as real_data.toml says) diagnosed three ways: as it is, under another processor's rounding
(OpenBLAS's Sandybridge kernels, numba compiling for a generic x86-64) and with its force
rescaled by 1 + 1e-9 at import. The verdict is what the diagnosis says: the effects it names,
those it says at the edge, and the groups it cannot tell apart (a finding's firm rivals); a
decision flipped is one held one way and not said at all (not even at the edge) another.

    .venv/bin/python -m tests.verdicts [--data ../shared/data] [--markdown] > docs/results/verdicts.md
"""
import json
import os
import subprocess
import tempfile
from pathlib import Path

from models.diagnose import stability
from tests.real_data import DYNO, files, generate

WAYS = {"as is": ({}, 1.0), "another kernel": ({"OPENBLAS_CORETYPE": "Sandybridge", "NUMBA_CPU_NAME": "generic"}, 1.0),
        "force x (1 + 1e-9)": ({}, 1.0 + 1e-9)}


def verdict(doc):
    """(named, at the edge, groups, said) of a diagnosis's JSON; said: {decision: "held" or
    "edge"} of every effect named or at the edge and every rival of a group's finding."""
    def said(share):
        return "held" if stability.holds(share) else "edge"
    found = [e for e in doc["effects"] if e.get("rivals") and not e["small"] and not e["stand_in"]]
    groups = sorted(" or ".join(sorted([e["effect"]] + [r["effect"] for r in e["rivals"] if stability.holds(r["held_in"])]))
                    for e in found if any(stability.holds(r["held_in"]) for r in e["rivals"]))
    decisions = {**{e: "held" for e in doc["named"]}, **{e: "edge" for e in doc["at_edge"]},
                 **{f"{e['effect']} ~ {r['effect']}": said(r["held_in"]) for e in found for r in e["rivals"]}}
    return [doc["named"], doc["at_edge"], groups, decisions]


def flipped(ways):
    """The decisions held one way and not said at all another (not even at the edge): a
    verdict flipped, where one only near its threshold moves between held and the edge."""
    ways = [v for v in ways if isinstance(v, list)]
    every = set().union(*(v[3] for v in ways)) if ways else set()
    return sorted(k for k in every if any(v[3].get(k) == "held" for v in ways) and any(k not in v[3] for v in ways))


def _with_gain(imports, factor):
    """The import arguments with the force's gain multiplied by factor."""
    out, gain, skip = [], 1.0, False
    for i, a in enumerate(imports):
        if skip:
            skip = False
        elif a == "--gain" and imports[i + 1].startswith("force="):
            gain, skip = float(imports[i + 1].split("=")[1]), True
        else:
            out.append(a)
    return out + (["--gain", f"force={gain * factor!r}"] if factor != 1.0 or gain != 1.0 else [])


def one(task):
    src, imports = task
    out = {"file": f"{src.parent.name}/{src.name}", "ways": {}}
    with tempfile.TemporaryDirectory() as d:
        for way, (env, factor) in WAYS.items():
            rec = Path(d) / f"{len(out['ways'])}.mcap"
            p = subprocess.run([DYNO, "import", str(src), "--out", str(rec), *_with_gain(imports, factor)],
                               capture_output=True, text=True)
            if p.returncode == 0:
                p = subprocess.run([DYNO, "diagnose", str(rec), "--json"], capture_output=True, text=True,
                                   env={**os.environ, **env})
            doc = json.loads(p.stdout) if p.returncode == 0 else None
            out["ways"][way] = (verdict(doc) if doc else {"error": (p.stderr.strip().splitlines() or ["?"])[-1]})
            out.setdefault("not_converged", 0)
            out["not_converged"] += doc["baseline"]["folds_not_converged"] if doc else 0
    return out


def markdown(results):
    import views.reports.markdown as md
    stamp = md.stamp().replace("`dyno ", "`python -m tests.verdicts ")
    same = lambda r, k: len({json.dumps(v[:k] if isinstance(v, list) else v) for v in r["ways"].values()}) == 1
    flips = {r["file"]: flipped(list(r["ways"].values())) for r in results}
    n = len(results)
    lines = ["# One verdict per recording", stamp, __doc__.split("\n\n")[0].replace("\n", " "),
             f"- the same named effects three ways: {sum(same(r, 1) for r in results)} of {n}",
             f"- the same named and at-the-edge effects: {sum(same(r, 2) for r in results)} of {n}",
             f"- the same verdict (named, at the edge, groups): {sum(same(r, 3) for r in results)} of {n}",
             f"- no decision flipped (held one way, not said at all another; held and at the edge is not a flip): "
             f"{sum(not f for f in flips.values())} of {n}" + "".join(f"; {k}: {', '.join(f)}" for k, f in flips.items() if f),
             f"- recordings whose baseline fit stopped at its step limit on a fold in any of the three ways: "
             f"{sum(r['not_converged'] > 0 for r in results)} of {n}", ""]
    rows = []
    for r in results:
        ways = list(r["ways"].values())
        said = ["; ".join(filter(None, ["named " + ", ".join(v[0]) if v[0] else "",
                                        "at the edge " + ", ".join(v[1]) if v[1] else "",
                                        "cannot tell " + ", ".join(v[2]) if v[2] else ""])) or "nothing"
                if isinstance(v, list) else v["error"] for v in ways]
        rows.append((r["file"], "same" if same(r, 3) else "differs", *said))
    lines.append(md.table(("file", "three ways", *WAYS), rows))
    return "\n".join(lines) + "\n"


def main(argv=None):
    generate("python -m tests.verdicts", argv, files, one, markdown, "recordings")


if __name__ == "__main__":
    main()
