"""`dyno prove` over forms, sizes and a pair, through the wires: a quick subset of the
matrix in docs/results/prove.md (one seed, ten times the concealed size)."""
import json
import subprocess
import sys


def test_prove_runs_the_form_matrix_and_a_pair():
    r = subprocess.run([sys.executable, "-m", "protocols.app.cli", "prove", "--effects",
                        "compressibility,fluid_inertia+sensor_delay,null", "--forms", "all", "--sizes", "10",
                        "--seeds", "1", "--jobs", "1", "--json"], capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr
    rows = {(row["effect"], row["form"]): row for row in json.loads(r.stdout)["effects"]}
    assert set(rows) == {("compressibility", "default"), ("compressibility", "pressure"),
                         ("fluid_inertia+sensor_delay", "default"), ("null", None)}
    # ten times the noise floor: both forms of compressibility are named first, the pair both
    assert all(rows[("compressibility", f)]["detection"] == 1.0 for f in ("default", "pressure"))
    assert rows[("fluid_inertia+sensor_delay", "default")]["detection"] == 1.0
    assert rows[("null", None)]["false_positive"] == 0.0
    assert all(row["contribution_rms"] > 1.5 for k, row in rows.items() if k[0] != "null")
