"""Issue 89: a lab's numbers right, or said unknown. A cut last row is never data; a date
comes only from the data; volts are not read as metres."""
import numpy as np
import pytest

from records.reader import load_recording
from tests.conftest import dyno
from tests.test_foreign_import import crank


def _crank_csv(n=1200, fmt="{:.4f},{:.4f},{:.2f}\n"):
    t, x, F = crank(n=n)
    return "t,x,F\n" + "".join(fmt.format(a, 1e3 * b, c) for a, b, c in zip(t, x, F)), F


@pytest.mark.parametrize("cut, said", [
    (lambda s: s.rstrip("\n")[:-3], "the file stops inside its last row"),  # mid-number, no line end
    (lambda s: s.rstrip("\n").rsplit(",", 1)[0], "the file stops inside its last row"),  # short of a column
    (lambda s: s.rstrip("\n"), None),  # a whole last row without its line end is data
])
def test_a_row_the_file_stops_inside_is_said_and_never_data(tmp_path, cut, said):
    text, F = _crank_csv()
    src = tmp_path / "cut.csv"
    src.write_text(cut(text))
    out = tmp_path / "cut.mcap"
    r = dyno("import", src, "--map", "time=t", "--map", "displacement=x:mm", "--map", "force=F", "--out", out)
    assert r.returncode == 0, r.stderr
    force = load_recording(out)[0]["force"][1]
    if said is None:
        assert len(force) == len(F) and "stops inside" not in r.stdout
        assert force[-1] == pytest.approx(F[-1], abs=0.01)
        return
    assert f"line {len(F) + 1}: {said}" in r.stdout, r.stdout
    assert len(force) == len(F) - 1 and np.allclose(force, F[:-1], atol=0.006)
