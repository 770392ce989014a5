"""The dyno commands as a user runs them: in this process (conftest.dyno, the console
script's own main), and the console script itself where the entry point is the point."""
import json
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import dyno as run

DYNO = [str(Path(sys.executable).parent / "dyno")]


def script(*args):
    return subprocess.run(DYNO + list(args), capture_output=True, text=True, timeout=600)


def test_validate_json_has_required_rows_and_pass_rates():
    p = run("validate", "--json")
    assert p.returncode == 0, p.stderr
    rows = json.loads(p.stdout)["rows"]
    keys = {"source", "group", "case", "unit", "thesis", "model", "rel_error", "tolerance",
            "tolerance_type", "pass"}
    assert all(keys <= set(r) for r in rows)
    sources = {r["source"] for r in rows}
    assert {"Table 4.1", "Table 6.1", "Sec 2.2.2", "Sec 4.3", "Sec 4.2.2.2"} <= sources
    assert {"Table 5.3", "Sec 6.2.1", "Table 6.2", "Table 6.3", "Table 6.4", "Table 6.5", "Table 6.6"} <= sources
    for damper in ("koni", "mechformance", "fox-light", "fox-heavy"):
        assert sum(r["source"] == "Table 6.1" and r["case"].startswith(damper) for r in rows) == 2
        assert sum(r["source"] == "Table 6.4" and r["case"].startswith(damper) for r in rows) == 8
        assert sum(r["source"] == "Table 6.5" and r["case"].startswith(damper) for r in rows) == 1
        assert sum(r["source"] == "Table 6.6" and r["case"].startswith(damper) for r in rows) == 4
    damper = [r for r in rows if r["group"] == "damper"]
    car = [r for r in rows if r["group"] == "quarter-car"]
    assert sum(r["pass"] for r in damper) >= 0.8 * len(damper)
    assert sum(r["pass"] for r in car) >= 0.7 * len(car)
    # the human table is the same rows
    from models.validation import format_table
    text = format_table(rows)
    assert "quarter-car rows:" in text and "Table 6.4" in text and "+-1 Hz" in text


def test_plot_damper_writes_pngs(tmp_path):
    p = run("plot", "damper", "koni", "--out", str(tmp_path), "--freq", "2", "16")
    assert p.returncode == 0, p.stderr
    pngs = sorted(tmp_path.glob("*.png"))
    assert len(pngs) == 5
    assert all(f.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and f.stat().st_size > 10_000 for f in pngs)


@pytest.mark.parametrize("args, message", [
    (("plot", "damper", "konni", "--out", "/tmp/x"), "unknown damper preset 'konni'"),
    (("plot", "damper", "koni", "--out", "/tmp/x", "--amplitude-mm", "60"), "--amplitude-mm"),
    (("plot", "damper", "koni", "--out", "/tmp/x", "--temp", "900"), "gas volume exhausted"),
])
def test_bad_input_is_one_line_and_nonzero(args, message):
    p = run(*args)
    assert p.returncode == 2
    assert "Traceback" not in p.stderr
    assert len(p.stderr.strip().splitlines()) == 1 and message in p.stderr


def test_incomplete_damper_json_names_the_field(tmp_path):
    f = tmp_path / "mine.json"
    data = json.loads(Path(__file__).parents[1].joinpath("models/presets/koni.json").read_text())
    del data["friction"]["C_sfT"]
    f.write_text(json.dumps(data))
    p = run("plot", "damper", str(f), "--out", str(tmp_path / "plots"))
    assert p.returncode == 2
    assert p.stderr.strip() == "dyno: error: mine.json: friction.C_sfT: missing"


def test_bench_sim_json_keys():
    p = run("bench", "sim", "--json", "--seconds", "0.2", "--ref-seconds", "0.05")
    assert p.returncode == 0, p.stderr
    cases = json.loads(p.stdout)["cases"]
    assert set(cases) == {"koni", "fox-heavy"}
    for c in cases.values():
        assert {"realtime_factor", "speedup_vs_reference", "max_force_diff_fraction"} <= set(c)
        assert c["max_force_diff_fraction"] < 0.005


def test_plot_quarter_car_writes_frequency_and_step_pngs(tmp_path):
    p = run("plot", "quarter-car", "--damper", "fox-light", "--out", str(tmp_path), "--freq", "3", "9",
            "--amplitude-mm", "3.2", "--workers", "1")
    assert p.returncode == 0, p.stderr
    pngs = sorted(f.name for f in tmp_path.glob("*.png"))
    assert pngs == ["frequency-response-fox-light.png", "step-response-fox-light.png"]
    assert all(f.stat().st_size > 20_000 for f in tmp_path.glob("*.png"))
    assert "2/2" in p.stderr  # the progress bar


@pytest.mark.parametrize("extra, message", [
    (("--freq", "0", "5"), "frequencies must be positive"),
    (("--amplitude-mm", "45"), "bottoms the suspension"),
    (("--car", "lorry"), "unknown quarter-car 'lorry'"),
])
def test_quarter_car_bad_input_is_one_line(tmp_path, extra, message):
    p = run("plot", "quarter-car", "--out", str(tmp_path), *extra)
    assert p.returncode == 2
    assert len(p.stderr.strip().splitlines()) == 1 and message in p.stderr, p.stderr


def test_negative_mass_car_file_is_named(tmp_path):
    car = tmp_path / "car.json"
    car.write_text(json.dumps({"name": "bad", "m_s": -250.0, "m_u": 45.0, "k_s": 7e4, "k_t": 3.5e5,
                               "c_tire": 0.0, "F_c1": 0.0, "F_c3": 0.0}))
    p = run("plot", "quarter-car", "--car", str(car), "--out", str(tmp_path / "plots"))
    assert p.returncode == 2
    assert p.stderr.strip() == "dyno: error: car.json: m_s: must be positive, got -250.0"


def test_every_protocol_parameter_is_described_and_nothing_else():
    import dataclasses
    import tomllib

    from protocols.library import DESCRIPTIONS, PROTOCOLS
    doc = tomllib.loads(DESCRIPTIONS.read_text())
    assert set(doc) == set(PROTOCOLS) | {"discover"}  # discover: a summary, the sine matrix's parameters
    for name, module in PROTOCOLS.items():
        assert set(doc[name]["params"]) == {f.name for f in dataclasses.fields(module.Params)}, name
        assert all(" | " in v for v in doc[name]["params"].values()), name


def test_protocols_and_a_protocols_help_list_parameters_with_defaults_and_units():
    p = run("protocols")
    assert p.returncode == 0 and all(n in p.stdout for n in ("static", "sine-matrix", "hil", "replay"))
    p = run("run", "--rig", "x.toml", "hil", "--help")
    assert p.returncode == 0, p.stderr
    line = next(ln for ln in p.stdout.splitlines() if ln.strip().startswith("guard_mm"))
    assert line.split()[1:3] == ["2.0", "mm"]
    p = run("run", "--help")
    assert p.returncode == 0 and "dyno run PROTOCOL --help" in p.stdout


def test_dyno_alone_lists_the_commands_and_a_typo_gets_the_nearest():
    p = script()
    assert p.returncode == 2 and "diagnose" in p.stderr and "where the model misses a recording" in p.stderr
    p = script("reprot", "x.mcap")
    assert p.returncode == 2 and p.stderr.strip() == ("dyno: error: unknown command 'reprot'; did you mean 'report'? "
                                                      "(dyno alone lists the commands)")


def test_discover_is_among_the_protocols_with_its_own_help():
    p = run("protocols")
    assert p.returncode == 0 and any(ln.startswith("discover ") and "--budget" in ln for ln in p.stdout.splitlines())
    p = run("run", "discover", "--help")
    assert p.returncode == 0 and p.stdout.startswith("dyno run discover [name=value ...] [options] [--budget SECONDS]")
    line = next(ln for ln in p.stdout.splitlines() if ln.strip().startswith("amplitudes_mm"))
    assert line.split()[1:3] == ["12.7,3.2", "mm"]  # the opening's defaults, not the sine matrix's
