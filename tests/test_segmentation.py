"""Issue 88: other dynos' programs (tests/programs.py, written apart from our own plans) cut
into their tests at any rate, with and without an LVDT's noise and an ADC's quantisation:
every steady sine found whole with its frequency within 0.2 % and its amplitude within 1 %,
none invented in a ramp, a hold or a sweep, every other piece read as what it is, nothing
left unread; then imported and diagnosed as a user would."""
import math
import os

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from records import segmentation, strokes
from records.reader import load_recording
from tests import drawn
from tests import programs as P
from tests.conftest import dyno

SINE_PROGRAMS = ("ramped", "stepped", "dwells", "lab", "mixed")
OTHER_PROGRAMS = ("sweeps", "triangles", "random", "static")
AS_ITSELF = 0.9  # of a piece's time read as its own kind (a ramp's last moments may be a dwell's first)


def cut(program, rate, noise="lvdt", seed=1):
    t, x = P.sample(program, rate, *P.NOISES[noise], seed=seed)
    segs = segmentation.find(t, x)
    return t, x, segs, P.score(program, [(s.kind, s.t0, s.t1, s.params) for s in segs], t[-1])


@pytest.mark.parametrize("rate", [300.0, 10000.0])
@pytest.mark.parametrize("name", SINE_PROGRAMS)
def test_every_steady_sine_of_a_lab_program_is_found_whole(name, rate):
    """The slowest and fastest acquisitions of the range, with an LVDT's noise (the whole
    grid, clean and noisy at 300 Hz to 10 kHz: docs/results/segmentation.md)."""
    t, _, segs, sc = cut(P.PROGRAMS[name](), rate)
    assert sc.sines and sc.found == sc.sines, sc.missed
    assert sc.invented == 0
    assert sc.freq_err <= P.FREQ_TOL and sc.amp_err <= P.AMP_TOL
    assert sc.unread_s < 1 / rate, sc.unread_s  # every second of it in a segment
    assert all(v >= AS_ITSELF for v in sc.kinds.values()), sc.kinds


@pytest.mark.parametrize("rate", [300.0, 10000.0])
@pytest.mark.parametrize("name", OTHER_PROGRAMS)
def test_sweeps_triangles_random_and_holds_are_read_as_what_they_are(name, rate):
    program = P.PROGRAMS[name]()
    t, x, segs, sc = cut(program, rate)
    assert sc.invented == 0 and sc.unread_s < 1 / rate
    assert all(v >= AS_ITSELF for v in sc.kinds.values()), sc.kinds
    if name == "triangles":  # constant-velocity strokes: their speed is 4 A f
        tri = [s for s in segs if s.params.get("waveform") == "triangle"]
        for s, p in zip(tri, [p for p in program.pieces if p.kind == "triangle"]):
            assert s.params["freq_hz"] == pytest.approx(p.freq, rel=P.FREQ_TOL)
            assert s.params["amplitude_mm"] * 1e-3 == pytest.approx(p.amplitude, rel=P.AMP_TOL)
    if name == "sweeps":  # the instantaneous frequency, the law's, along each sweep's steady part
        for p in [p for p in program.pieces if p.kind == "sweep"]:
            at = np.linspace(p.t0 + 2 / p.freq, p.t1 - 2 / p.freq_end, 9)
            f = strokes.frequency(t, x, p.t0, p.t1, at=at)
            assert np.allclose(f, program.freq_at(at), rtol=0.01), (f, program.freq_at(at))


class _Hypothesis:
    """tests/drawn.py's picks, drawn by hypothesis (which shrinks a failing program)."""

    def __init__(self, draw):
        self.draw = draw

    def real(self, lo, hi):
        return self.draw(st.floats(lo, hi))

    def whole(self, lo, hi):
        return self.draw(st.integers(lo, hi))

    def one(self, options):
        return self.draw(st.sampled_from(options))

    def keep(self, ok):
        assume(ok)
        return True


sine_programs = st.composite(lambda draw: drawn.program(_Hypothesis(draw)))


@settings(max_examples=int(os.environ.get("DYNO_PROPERTY_EXAMPLES", "25")), deadline=None, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(program=sine_programs(), rate=st.floats(*map(math.log, drawn.RATE_HZ)).map(math.exp),
       noise=st.sampled_from(sorted(P.NOISES)), seed=st.integers(0, 2 ** 16))
def test_any_sine_program_at_any_rate_is_cut_right(program, rate, noise, seed):
    """Property: every steady sine found whole within tolerance, none invented in a ramp or
    a hold, nothing unread (DYNO_PROPERTY_EXAMPLES sets the number of programs). At 400 it
    found four cuts wrong (2026-12-05): a stepped sine's period read across the step, a
    seed that let the half-cycle joining two tests in, a seed of three half-cycles whose
    frequency held loosely, a ramp's first half-cycle alike to the sine before it. Thousands
    more are drawn for the table (tests/segmentation_grid.py --drawn)."""
    t, _, _, sc = cut(program, rate, noise, seed)
    assert P.cut_right(sc, rate), (sc.missed, sc.invented, sc.unread_s)


# programs the property above drew wrong (26 of 10,000 drawn alike, 2026-12-07): a sine stepped
# straight into the next, or from a hold or a dwell, each at the rate and noise it failed at
STEPPED = {
    "into its neighbour": (lambda b: b.hold(1.0).sine(0.0126, 9.09, 5, 0).sine(0.01112, 10.58, 5, 0).hold(1.0),
                           585.0, "lvdt"),
    "from a hold into a ramp": (lambda b: b.hold(1.0).sine(0.0018, 7.97, 2, 0).sine(0.00647, 2.66, 2).hold(1.0),
                                1461.0, "clean"),
    "from a dwell after a taper": (lambda b: b.hold(0.6).sine(0.0115, 6.65, 4).hold(2.0).sine(0.00314, 1.9, 2, 0)
                                   .hold(0.5), 2563.0, "lvdt"),
    "small and fast after two slow": (lambda b: b.hold(1.0).sine(0.0039, 1.0, 2, 0).sine(0.0078, 1.0, 2, 0)
                                      .sine(0.00195, 4.0, 2, 0).hold(1.0), 403.0, "clean"),
}


@pytest.mark.parametrize("name", STEPPED)
def test_a_sine_stepped_from_another_or_from_rest_is_found_whole(name):
    """Each stretch a steady test holds is cut where the motion leaves its fit for the next
    test's before its whole cycles are counted, and a seed's frequency is searched about its
    own half-cycles' period. Before: the test found first kept the samples where the two
    stepped tests agree and the next lost a cycle; a seed searched about a fit bent by the
    joining half-cycle (8 % off) missed a 2 cycle sine, and one whose period reached across a
    dwell fitted 0.65 Hz to a 1.9 Hz sine."""
    build, rate, noise = STEPPED[name]
    program = build(P.Builder(name)).build()
    _, _, segs, sc = cut(program, rate, noise)
    assert sc.found == sc.sines and sc.invented == 0, (sc.missed, [(s.name, round(s.t0, 3)) for s in segs])


@pytest.mark.parametrize("rate", [300.0, 1000.0, 5000.0])
def test_a_chirp_from_rest_under_a_daq_s_spikes_is_one_sweep_from_its_first_stroke(rate):
    """UTFSM's chirps: a sweep that starts from a hold at its first phase, its first strokes
    seconds long, on a displacement with a DAQ's spikes. The spikes cut the slow crests into
    strokes of tens of micrometres: the first quarter cycle was read as a step, the crests as
    dwells and the first cycle as random motion, and the sweep's start frequency was read
    from the broken strokes (1.2-15 Hz for 0.2 Hz rising to 0.7 Hz over its first strokes)."""
    program = P.PROGRAMS["chirp"]()
    sweep = next(p for p in program.pieces if p.kind == "sweep")
    for seed in (1, 2, 3):
        t, x = P.sample(program, rate, *P.SPIKY["spikes"], seed=seed)
        segs = segmentation.find(t, x)
        sc = P.score(program, [(s.kind, s.t0, s.t1, s.params) for s in segs], t[-1])
        first = next(s for s in segs if s.t1 > sweep.t0 + 0.5)  # what the sweep's start is read as
        assert first.kind == "sweep" and abs(first.t0 - sweep.t0) < 0.1, (seed, [(s.name, s.t0) for s in segs])
        assert sc.kinds["sweep"] >= 0.99 and sc.unread_s < 1 / rate, (seed, sc.kinds)
        assert 0.2 <= first.params["f_start_hz"] <= program.freq_at(np.array([sweep.t0 + 3.0]))[0], (seed, first)


@pytest.mark.parametrize("rate", [300.0, 1000.0, 5000.0])
def test_slow_sines_under_a_daq_s_spikes_are_found_whole(rate):
    """Sines of 3.2 mm at 0.5 to 4 Hz under a DAQ's spikes (tests/programs.py): the steady
    tests are read from strokes of MIN_TRAVEL, which the spikes do not cut. Read from strokes
    the noise alone bounds, the 0.5 and 1 Hz sines were cut into strokes of tens of
    micrometres at their slow crests, and no run of alike strokes seeded them (1 or 2 of 4
    found, every seed and rate)."""
    b = P.Builder("slow").hold(1.0)
    for f in (0.5, 1.0, 2.0, 4.0):
        b.sine(0.0032, f, 4).hold(0.5)
    program = b.hold(0.5).build()
    for seed in (1, 2, 3):
        t, x = P.sample(program, rate, *P.SPIKY["spikes"], seed=seed)
        segs = segmentation.find(t, x)
        sc = P.score(program, [(s.kind, s.t0, s.t1, s.params) for s in segs], t[-1])
        assert sc.found == sc.sines == 4 and sc.invented == 0, (seed, sc.missed)


def _imported(tmp_path, program, rate, **force):
    """The program as another lab's CSV (time, displacement in mm, force), imported."""
    t, x = P.sample(program, rate, P.LVDT_NOISE_M, P.LVDT_QUANTUM_M, seed=1)
    src = tmp_path / "lab.csv"
    np.savetxt(src, np.c_[t, x * 1e3, P.damper_force(program, t, seed=1, **force)], fmt="%.6f", delimiter=",",
               header="t,x,F", comments="")
    rec = tmp_path / "lab.mcap"
    r = dyno("import", src, "--out", rec, "--map", "time=t", "--map", "displacement=x:mm", "--map", "force=F")
    assert r.returncode == 0, r.stderr
    return rec, r.stdout


def test_the_import_says_how_a_70_s_matrix_divides_and_leaves_none_of_it(tmp_path):
    """The issue's 70 s matrix at 5 kHz (4 cycles a sine, a 2 Hz reference between blocks):
    42 s of it were "not in a segment"; now each of its 27 sines, their ramps and dwells."""
    program = P.lab_matrix()
    rec, out = _imported(tmp_path, program, 5000.0)
    line = next(s for s in out.splitlines() if s.startswith("segments: "))
    shares = {k: float(v) for v, k in [(p.split(" % in ")[0], p.split(" % in ")[1].split(" ", 1)[1])
                                       for p in line.removeprefix("segments: ").split(";")[0].split(", ")]}
    assert line.startswith("segments: 61 % in 27 sines"), line
    assert set(shares) == {"sines", "ramps", "dwells", "holds"} and sum(shares.values()) >= 99, line
    ch, events, _ = load_recording(rec)
    assert [s.name for s in segmentation.cut(ch, events) if s.kind == "sine"] == [
        s.name for s in segmentation.find(*P.sample(program, 5000.0, P.LVDT_NOISE_M, P.LVDT_QUANTUM_M, seed=1))
        if s.kind == "sine"]  # the cut the import stored is the one found


# a shorter matrix (37 s: 6.4 and 1.6 mm, 1-16 Hz) at 5 kHz: the effects the issue says were
# never seen, each where only a part of the program holds it
EFFECTS = {"null": ({}, set()), "fade above 8 Hz": ({"fade_above_hz": 8.0}, {"frequency_damping"}),
           "friction rising near reversal": ({"reversal": 2.0}, {"breakaway_friction"})}


@pytest.mark.rounding
@pytest.mark.parametrize("case", EFFECTS)
def test_an_effect_in_part_of_a_lab_program_is_named(tmp_path, case):
    """Damping that falls 30 % above 8 Hz lives in six of the fifteen sines (8-16 Hz) and their ramps;
    friction that doubles near reversal lives at the lowest speeds of every stroke; neither
    is in the plain model, and a null names nothing (measured 2026-12-05: 4-15 s each)."""
    from models.diagnose import diagnose
    force, named = EFFECTS[case]
    rec, _ = _imported(tmp_path, P.lab_matrix((0.0064, 0.0016)), 5000.0, **force)
    res = diagnose(*load_recording(rec)[:2])
    assert set(res.named()) == named, (res.named(), res.at_edge())
