"""`dyno prove` over forms, sizes and a pair, through the wires: a quick subset of the
matrix in docs/results/prove.md (one seed, ten times the concealed size; the whole matrix is
`dyno prove --forms all`)."""
import json
import subprocess
import sys


def test_prove_runs_another_form_and_a_pair():
    r = subprocess.run([sys.executable, "-m", "protocols.app.cli", "prove", "--effects",
                        "free_play:hertz,fluid_inertia+sensor_delay,null", "--sizes", "10",
                        "--seeds", "1", "--jobs", "1", "--json"], capture_output=True, text=True, timeout=900)
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
    r = subprocess.run([sys.executable, "-m", "protocols.app.cli", "prove", "--effects", "free_play:rubber"],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "free_play:rubber: no such form" in r.stderr and "Traceback" not in r.stderr
