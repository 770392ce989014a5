"""The dyno's own next test, closed (protocols/discover.py): an opening on the direct cell,
a diagnosis, the designed sines run on the same cell into the same record with their
reasons as events, and a diagnosis again. The wired path: tests/test_wired.py."""
import re

import numpy as np
import pytest

from models.diagnose import design
from records.data import segments
from protocols import cell
from protocols.discover import discover, next_plan
from protocols.library import sine_matrix
from protocols.plan import ParamError, Plan, parse, rig_info
from protocols.runner import Kept
from rig import config
from sim_backend.options import plant_options

OPENING = ["amplitudes_mm=6.4,1.6", "freqs_hz=2,8", "record_cycles=4", "settle_cycles=1"]


def test_the_next_plan_takes_the_rig_time_the_design_counted():
    sines = [design.Sine(0.002, 25.0, 0.04), design.Sine(0.0005, 0.5, 0.04)]
    props = [design.Proposal(s, None, 0.0, 0.0, 0.0, "") for s in sines]
    plan = next_plan(props)
    info = rig_info(config.load("virtual"), None)
    segs = list(plan.module.plan(plan.params, info))
    assert sum(s.duration for s in segs) == np.sum([s.rig_s for s in sines])
    recorded = [s for s in segs if s.record]
    assert [(s.params["amplitude_mm"], s.params["freq_hz"]) for s in recorded] == [(2.0, 25.0), (0.5, 0.5)]
    assert [s.duration for s in recorded] == [s.cycles / s.frequency_hz - design.SETTLE_CYCLES / s.frequency_hz
                                              for s in sines]


def test_discovery_runs_the_designed_sines_with_their_reasons_and_diagnoses_again():
    plant = plant_options(None, ["sensor_delay=3e-4"], plain=True, seed=1)
    kept = Kept()
    with cell.direct(config.load("virtual"), plant.damper, plant) as c:
        found = discover(Plan(sine_matrix, parse(sine_matrix.Params, OPENING)), c, [kept], budget_s=3.0,
                         max_rounds=1)
    assert len(found.rounds) == 2 and len(found.runs) == 2 and found.result.fault is None
    asked = found.rounds[0].ran
    assert asked and found.spent_s == sum(a["rig_s"] for a in asked) <= 3.0
    assert all(a["why"] and "differ by" in a["why"] for a in asked)
    ev = kept.events
    kinds = [e.kind for e in ev]
    assert kinds.count("run_start") == 2 and kinds.count("diagnosis") == 2
    assert ev[-1].kind == "run_end" and ev[-1].segment == "discover" and ev[-1].message == "completed"
    # it ends with a verdict a test engineer reads: found, unresolved, why it stopped
    assert ev[-2].kind == "verdict" and ev[-2].message == found.verdict
    assert found.verdict.startswith("Found: a timing offset of the cell") and "Stopped: the round limit of its own tests (1)" in found.verdict
    assert ev[-2].params["stopped"].startswith("the round limit") and ev[-2].params["spent_s"] == found.spent_s
    # each reason is told before its sine runs, and the sine is recorded after it
    second = kinds.index("run_start", 1)
    told = [e for e in ev if e.kind == "next_test"]
    assert [e.message for e in told] == [a["why"] for a in asked]
    assert all(ev.index(e) < second for e in told)
    after = [n for n, _, t0, _ in segments(ev) if t0 >= ev[second].t]
    assert after == [e.segment for e in told]
    # the first diagnosis names the hidden lag, and the last one still does with more data
    assert "sensor_delay" in found.rounds[0].accepted and "sensor_delay" in found.diagnosis.accepted


def test_paired_sines_are_checked_as_pairs():
    info = rig_info(config.load("virtual"), None)
    p = parse(sine_matrix.Params, ["amplitudes_mm=1,2", "freqs_hz=3,4", "paired=true"])
    assert [s.name for s in sine_matrix.plan(p, info) if s.record] == ["sine 1 mm 3 Hz", "sine 2 mm 4 Hz"]
    for bad, said in ((["paired=maybe"], "paired: 'maybe' is not true or false"),
                      (["amplitudes_mm=1,2", "freqs_hz=3", "paired=true"], "paired: 2 amplitudes_mm for 1 freqs_hz"),
                      (["record_s=-1"], "record_s: must be 0 or more")):
        with pytest.raises(ParamError, match=re.escape(said)):
            sine_matrix.check(parse(sine_matrix.Params, bad), info)


def test_a_real_cells_discover_reads_no_simulator_file():
    """Issue 46: the opening and the proven envelope come from protocols/proven.toml, so
    `dyno run discover --rig CELL.toml` on a real cell reads nothing of the simulator's:
    discover's planning imports and runs with the simulator's package unavailable."""
    import subprocess
    import sys
    code = ("import sys; sys.modules['sim_backend'] = None\n"
            "from protocols.discover import limits\nfrom protocols.proven import opening\n"
            "from rig import config\nlim = limits(config.load('virtual'))\n"
            "print(round(lim.velocity_proven, 3), opening()[1]['freqs_hz'])")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and r.stdout.split() == ["1.277", "[2.0,", "4.0,", "8.0,", "16.0]"], r.stderr
