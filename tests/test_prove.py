"""`dyno prove` over forms, sizes and a pair, through the wires: a quick subset of the
matrix in docs/results/prove.md (one seed, ten times the concealed size; the whole matrix is
`dyno prove --forms all`)."""
import json
import re
import subprocess
import sys

from tests.conftest import operator_stopped


def test_prove_runs_another_form_and_a_pair(prove_keep):
    r = subprocess.run([sys.executable, "-m", "commands.cli", "prove", "--effects",
                        "free_play:hertz,fluid_inertia+sensor_delay,null", "--sizes", "10",
                        "--seeds", "1", "--jobs", "1", "--keep", prove_keep, "--json"], capture_output=True, text=True,
                       timeout=900)
    assert r.returncode == 0, r.stderr
    rows = {(row["effect"], row["form"]): row for row in json.loads(r.stdout)["effects"]}
    assert set(rows) == {("free_play", "hertz"), ("fluid_inertia+sensor_delay", "default"), ("null", None)}
    # ten times the noise floor: free play closing onto a Hertzian contact (the candidate's
    # contact is rigid) is named first, the pair both
    assert rows[("free_play", "hertz")]["detection"] == 1.0
    assert rows[("fluid_inertia+sensor_delay", "default")]["detection"] == 1.0
    assert rows[("null", None)]["false_positive"] == 0.0
    assert all(row["contribution_rms"] > 1.5 for k, row in rows.items() if k[0] != "null")


def test_an_unknown_form_is_named():
    r = subprocess.run([sys.executable, "-m", "commands.cli", "prove", "--effects", "free_play:rubber"],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "free_play:rubber: no such form" in r.stderr and "Traceback" not in r.stderr


def test_rows_beyond_the_plant_s_range_are_left_out_and_said():
    """Issue 90 (make results): a matrix of noise levels asks gas temperature at noise x10
    for a fraction above 1; that row is left out and said, the rest run. A matrix with
    nothing left to hide is refused, naming the bound."""
    import pytest
    from proof.on_plant import matrix
    from rig.errors import UsageError
    from sim_backend.options import plain_cell
    concealed = plain_cell()[2]["concealed"]
    _, tasks, beyond = matrix("gas_temperature,free_play,null", False, [1.0], [1.0, 10.0], [1000.0], 1, 0.0,
                              concealed)
    assert [r for r, _ in beyond] == ["gas_temperature x1 at noise x10"], beyond
    assert "VALUE must be a number from 0 to 1" in beyond[0][1]
    ran = {(t.effect, t.noise) for t in tasks}
    assert ("gas_temperature", 1.0) in ran and ("free_play", 10.0) in ran and ("gas_temperature", 10.0) not in ran
    with pytest.raises(UsageError, match="VALUE must be a number from 0 to 1"):
        matrix("gas_temperature", False, [1.0], [10.0], [1000.0], 1, 0.0, concealed)


def test_the_named_effect_s_own_estimate_and_none_where_it_has_no_one_value():
    """Issue 90 (make results): friction along the bore named first at noise x10 has no
    single value to report; prove-noise failed on it (KeyError: None). Its estimate is
    None; a sensor delay's is its own tau, before the alignment it took the place of."""
    from types import SimpleNamespace as NS
    from proof.on_plant import own_estimate
    r = NS(steps=[NS(effect="position_friction", parameters={"pf0": 3.0})],
           baseline=NS(cell=[NS(effect="alignment", parameters={"tau_0": 2e-5})]))
    assert own_estimate(r, "position_friction") is None
    assert own_estimate(r, "sensor_delay") == 2e-5


def test_a_kept_run_is_taken_not_run_again_and_only_by_the_same_code(tmp_path, monkeypatch):
    """`dyno prove --keep`: each result is kept as it comes in; a task kept is taken from the
    folder, the others run (and kept); a cut-short file is run again; other code reuses nothing."""
    from proof import keep, on_plant as proof
    ran = []
    monkeypatch.setattr(proof, "run_task", lambda t: ran.append(t.seed) or {"seed": t.seed, "run": len(ran)})
    tasks = [proof.ProveTask(None, None, 1.0, None, seed, 1.0, 1000.0) for seed in (0, 1)]
    where = keep.folder(tmp_path / "kept")
    keep.save(where, tasks[0], {"seed": 0, "run": "before"})
    said = []
    got = proof.run_tasks(tasks, None, "prove", where, said.append)
    assert ran == [1] and got == [{"seed": 0, "run": "before"}, {"seed": 1, "run": 1}]
    assert said == [f"prove: 1 of 2 runs kept in {where}, not run again"]
    assert keep.load(where, tasks[1]) == {"seed": 1, "run": 1}
    for f in where.glob("*.pkl"):
        f.write_bytes(b"\x80")  # writes cut short: run again
    assert keep.load(where, tasks[0]) is None and keep.load(where, tasks[1]) is None
    keep.save(where, tasks[0], {"seed": 0})
    monkeypatch.setattr(keep, "code", lambda: "other code")
    assert keep.load(where, tasks[0]) is None


def test_a_keep_folder_that_is_a_file_is_one_line(tmp_path):
    (tmp_path / "f").write_text("")
    r = subprocess.run([sys.executable, "-m", "commands.cli", "prove", "--effects", "null", "--seeds", "1",
                        "--keep", str(tmp_path / "f")], capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "--keep" in r.stderr and "is a file" in r.stderr and "Traceback" not in r.stderr


def test_a_sigterm_ends_prove_and_its_workers_at_once(tmp_path):
    """SIGTERM reaches the parent alone: it ends its pool's workers, which would otherwise run
    their recordings and diagnoses to the end (at 5 kHz, minutes) while it waited for them."""
    import time
    from pathlib import Path
    p = subprocess.Popen([sys.executable, "-m", "commands.cli", "prove", "--effects", "free_play,null",
                          "--seeds", "2", "--rates", "5000", "--jobs", "2", "--keep", str(tmp_path / "kept")],
                         stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    children = Path(f"/proc/{p.pid}/task/{p.pid}/children")
    t0 = time.monotonic()
    while len(workers := children.read_text().split()) < 2 and time.monotonic() - t0 < 120:
        time.sleep(0.2)
    assert len(workers) == 2, p.stderr.read() if p.poll() is not None else "no workers"
    err = operator_stopped(p)
    assert re.search(r"prove: stopped; \d of 4 runs done, kept in .*kept: the same command goes on", err), err
    t0 = time.monotonic()
    while any(Path(f"/proc/{w}").exists() for w in workers) and time.monotonic() - t0 < 10:
        time.sleep(0.1)
    assert not any(Path(f"/proc/{w}").exists() for w in workers)
