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


def test_a_date_comes_from_the_data_or_is_said_unknown_and_import_order_sorts_the_trend(tmp_path):
    """A file without a date: "unknown" in the import's line, the recording, the sheet, the
    list and the trend, which takes the runs in the order imported, never the files' times
    (the first written last here). --start gives the date."""
    import os
    from protocols import catalogue
    from protocols.reports import trend as trend_report
    text, F = _crank_csv(n=1500)
    files = []
    for k, gain in enumerate((1.0, 1.2, 1.4)):  # a damper's force rising run by run
        src = tmp_path / f"run{k}.csv"
        src.write_text(text)
        os.utime(src, (1e9 - 1e6 * k, 1e9 - 1e6 * k))  # file times in the other order
        files.append((src, gain))
    for src, gain in files:
        r = dyno("import", src, "--map", "time=t", "--map", "displacement=x:mm", "--map", "force=F", "--gain",
                 f"force={gain}", "--serial", "D7", "--out", src.with_suffix(".mcap"))
        assert r.returncode == 0, r.stderr
        assert "rows from an unknown date (the file holds none: --start gives it)" in r.stdout, r.stdout
    meta = load_recording(files[0][0].with_suffix(".mcap"))[2]
    assert meta["run"]["wall_start"] == "unknown"
    listed = dyno("runs", "list", tmp_path).stdout
    assert listed.count("| unknown |") == 3 and "2001" not in listed and "1970" not in listed, listed
    with catalogue.reading(tmp_path) as c:
        points = catalogue.trend(c, "D7", "compression@0.1m/s")
    assert [s for s, *_ in points] == [None] * 3
    forces = [F for _, F, _, _ in points]
    assert forces[0] < forces[1] < forces[2], forces  # as imported
    trend_report.figure(points, "D7", "compression@0.1m/s", tmp_path / "trend.png")
    assert (tmp_path / "trend.png").stat().st_size > 10_000
    sheet = dyno("report", files[0][0].with_suffix(".mcap"), "--out", tmp_path / "r")
    assert sheet.returncode == 0, sheet.stderr
    page = (tmp_path / "r" / "index.html").read_text()
    assert "unknown" in page and "2001-" not in page and "1970-" not in page
    r = dyno("import", files[0][0], "--map", "time=t", "--map", "displacement=x:mm", "--map", "force=F",
             "--start", "2025-11-14T20:14:37", "--out", tmp_path / "dated.mcap")
    assert "rows from 2025-11-14T20:14:37.000 UTC (--start)" in r.stdout, r.stdout
    assert load_recording(tmp_path / "dated.mcap")[2]["run"]["wall_start"].startswith("2025-11-14T20:14:37")
    bad = dyno("import", files[0][0], "--map", "time=t", "--map", "displacement=x:mm", "--map", "force=F",
               "--start", "yesterday", "--out", tmp_path / "bad.mcap")
    assert bad.returncode != 0 and bad.stderr.strip().count("\n") == 0 and "--start yesterday" in bad.stderr
