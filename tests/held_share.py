"""The share of judgements a finding must hold in to be named (issue 71, stability.HELD),
measured: the prove runs kept by `dyno prove --keep DIR` (nulls and hidden effects on the
virtual rig), each finding's held_in read against several bars. On a null a finding of
physics held at the bar is a false name; on a run with an effect hidden, the hidden effect
held at the bar is a detection.

    dyno prove --effects null --seeds 20 --keep DIR
    dyno prove --effects ALL --seeds 2 --keep DIR
    .venv/bin/python -m tests.held_share DIR [--markdown] > docs/results/held-share.md
"""
import argparse
import pickle
from pathlib import Path

from models.diagnose import stability
from models.diagnose.candidates import EFFECTS
from proof.table import Outcome

BARS = (0.5, 0.6, stability.HELD, 0.8, 0.9, 1.0)


def _held(r, bar, natures=("physics", "open")):
    """What a run names at `bar` (its findings held in at least that share) of these natures:
    a cell's timing or the valve curve's form is no claim of physics."""
    return {f["effect"].split(":")[0] for f in r.found
            if f["held_in"] >= bar - 1e-12 and EFFECTS[f["effect"].split(":")[0]].nature in natures}


def table(runs):
    """Rows (bar, nulls with a false name, hidden effects named alone or among others)."""
    nulls = [r for r in runs if r.effect is None]
    hidden = [r for r in runs if r.effect is not None and "+" not in r.effect]
    rows = []
    for bar in BARS:
        false = sum(bool(_held(r, bar)) for r in nulls)
        edge = sum(bool(_held(r, stability.EDGE + 1e-9) - _held(r, bar)) for r in nulls)
        found = sum(r.effect in _held(r, bar, ("physics", "open", "cell", "form")) for r in hidden)
        rows.append((f"{bar:.2f}" + (" (HELD)" if bar == stability.HELD else ""), f"{false} of {len(nulls)}",
                     f"{edge} of {len(nulls)}", f"{found} of {len(hidden)}"))
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m tests.held_share")
    ap.add_argument("kept", nargs="+", help="folders of `dyno prove --keep`")
    ap.add_argument("--markdown", action="store_true")
    args = ap.parse_args(argv)
    runs = [pickle.loads(p.read_bytes()) for d in args.kept for p in sorted(Path(d).glob("*.pkl"))]
    runs = [r for r in runs if isinstance(r, Outcome)]  # kept by this code (older ones were dicts)
    rows = table(runs)
    if not args.markdown:
        for row in rows:
            print(*row, sep="\t")
        return
    import views.reports.markdown as md
    print("# The share a finding must hold in to be named")
    print(md.stamp().replace("`dyno ", "`python -m tests.held_share "))
    print(__doc__.split("\n\n")[0].replace("\n", " ") + f" {stability.SHIFTS * stability.DRAWS} judgements a "
          f"diagnosis; at the edge: held in more than {stability.EDGE:.2f} but less than the bar.\n")
    print(md.table(("bar (share of judgements)", "nulls naming physics", "nulls at the edge",
                    "hidden effects named"), rows))
    held = sorted(f["held_in"] for r in runs if r.effect and "+" not in r.effect for f in r.found
                  if f["effect"].split(":")[0] == r.effect)
    print(f"\nThe hidden effects' own shares (held_in), {len(held)} accepted of "
          f"{sum(bool(r.effect) for r in runs)} runs: {', '.join(f'{h:.2f}' for h in held)}.")


if __name__ == "__main__":
    main()
