"""Other dynos' programs (tests/programs.py) cut at every rate, clean, with an LVDT's noise
and quantisation, and with a DAQ's spikes besides: how many steady sines are found whole, the worst frequency and amplitude
errors, sines invented, seconds unread, each other kind of piece read as itself, and the
time the cut took; then the property test's random sine programs (tests/drawn.py), thousands
of them, and which are cut wrong. `python -m tests.segmentation_grid [--markdown] [--drawn N]`:
docs/results/segmentation.md."""
import argparse
import time
from concurrent.futures import ProcessPoolExecutor

from views.reports import markdown as md
from records import segmentation
from tests import drawn
from tests import programs as P


def rows():
    for name, make in P.PROGRAMS.items():
        program = make()
        for rate in P.RATES_HZ:
            for noise, spec in P.SPIKY.items():
                t, x = P.sample(program, rate, *spec, seed=1)
                t0 = time.perf_counter()
                segs = segmentation.find(t, x)
                took = time.perf_counter() - t0
                sc = P.score(program, [(s.kind, s.t0, s.t1, s.params) for s in segs], t[-1])
                kinds = ", ".join(f"{k} {100 * v:.0f} %" for k, v in sc.kinds.items())
                yield (name, f"{program.duration:.0f}", f"{rate:.0f}", noise,
                       f"{sc.found}/{sc.sines}" if sc.sines else "-", sc.invented,
                       f"{100 * sc.freq_err:.3f}" if sc.sines else "-", f"{100 * sc.amp_err:.2f}" if sc.sines else "-",
                       f"{sc.unread_s:.3f}", kinds, f"{took:.2f}")


HEADER = ("program", "s", "rate [Hz]", "noise", "sines found whole", "invented", "worst freq err [%]",
          "worst amp err [%]", "unread [s]", "pieces read as their kind", "cut [s]")


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m tests.segmentation_grid")
    ap.add_argument("--markdown", action="store_true")
    ap.add_argument("--drawn", type=int, default=4000, help="random sine programs drawn (seeds 0 to N - 1)")
    a = ap.parse_args(argv)
    segmentation.find(*P.sample(P.PROGRAMS["mixed"](), 1000.0))  # compiled before anything is timed
    table = list(rows())
    with ProcessPoolExecutor(2) as pool:
        wrong = [w for w in pool.map(drawn.cut_wrong, range(a.drawn), chunksize=50) if w is not None]
    if not a.markdown:
        for r in table:
            print("  ".join(str(v) for v in r))
        print(f"drawn: {len(wrong)} of {a.drawn} cut wrong", *wrong, sep="\n")
        return
    print("# Other dynos' programs, cut into their tests\n")
    print(md.stamp().replace("`dyno ", "`python -m tests.segmentation_grid "), "\n")
    print("Each program of tests/programs.py (written apart from our own plans) sampled at each rate, "
          f"clean, with an LVDT's noise ({P.LVDT_NOISE_M * 1e6:.0f} um RMS, 16 bits over 100 mm) and with a DAQ's "
          f"spikes besides ({P.SPIKES_PER_S:.0f} bursts a second of {P.SPIKE_M * 1e6:.0f} um RMS lasting "
          f"{P.SPIKE_S * 1e3:.0f} ms on average, as UTFSM's exports hold them; what every cut is held to in the tests "
          "is the clean and LVDT rows, the spikes rows say how far it falls short), cut by "
          "records/segmentation.find as `dyno import` cuts a file. A sine is found whole when one segment holds "
          f"every whole cycle, nothing past its steady stretch, its frequency within {100 * P.FREQ_TOL:.1f} % and "
          f"its amplitude within {100 * P.AMP_TOL:.0f} % (docs/recording.md). Invented: a sine segment where the "
          "program has no steady sine. Pieces read as their kind: the share of each kind of piece's time "
          "in a segment of that kind (a ramp's last moments may be read as the dwell after it).\n")
    print(md.table(HEADER, table))
    print(f"\n**Drawn at random**: {a.drawn:,} sine programs as the property test draws them "
          f"(tests/drawn.py: two to four sines ramped, stepped into the next or dwelling, numpy seeds 0 to "
          f"{a.drawn - 1:,}, each at a rate drawn log-uniform from {drawn.RATE_HZ[0]:.0f} Hz to "
          f"{drawn.RATE_HZ[1] / 1e3:.0f} kHz, clean or with the LVDT's noise): **{len(wrong)} cut wrong**"
          + ("." if not wrong else ":"))
    for w in wrong[:20]:
        print(f"- seed {w['seed']} at {w['rate_hz']} Hz ({w['noise']}): {w['found']} found whole, "
              f"{w['invented']} invented; " + "; ".join(w["missed"]))


if __name__ == "__main__":
    main()
