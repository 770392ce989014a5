"""`dyno prove` over forms, sizes and a pair, through the wires: a quick subset of the
matrix in docs/results/prove.md (one seed, ten times the concealed size)."""
import json
import subprocess
import sys


def test_prove_runs_the_form_matrix_and_a_pair():
    r = subprocess.run([sys.executable, "-m", "protocols.app.cli", "prove", "--effects",
                        "breakaway_friction,fluid_inertia+sensor_delay,null", "--forms", "all", "--sizes", "10",
                        "--seeds", "1", "--jobs", "1", "--json"], capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr
    rows = {(row["effect"], row["form"]): row for row in json.loads(r.stdout)["effects"]}
    assert set(rows) == {("breakaway_friction", "default"), ("breakaway_friction", "exponential"),
                         ("breakaway_friction", "lorentzian"), ("fluid_inertia+sensor_delay", "default"),
                         ("null", None)}
    # ten times the noise floor: every form of the breakaway is named first, the pair both
    assert all(rows[("breakaway_friction", f)]["detection"] == 1.0 for f in ("default", "exponential", "lorentzian"))
    assert rows[("fluid_inertia+sensor_delay", "default")]["detection"] == 1.0
    assert rows[("null", None)]["false_positive"] == 0.0
    assert all(row["contribution_rms"] > 1.5 for k, row in rows.items() if k[0] != "null")
