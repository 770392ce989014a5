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
    from views import run_index
    from views.reports import trend as trend_report
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
    with run_index.reading(tmp_path) as c:
        points = run_index.trend(c, "D7", "compression@0.1m/s")
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


def _daq(tmp_path, t, x, F):
    """A DAQ's raw text export as the UTFSM press wrote it: a preamble, CHANNEL0-1 in volts."""
    rows = [f"{i + 1:>10}, {a:.4f}, {(b - 0.0495) / 0.01:.5f}, {c / 980.665 + 0.01:.6f}"
            for i, (a, b, c) in enumerate(zip(t, x, F))]
    src = tmp_path / "daq.txt"
    src.write_text("Header Size:  7\nVersion:  2\nSampling Interval:  0.001\nSampling Rate:  1000\nSample Count:  "
                   f"{len(t)}\nDevice Serial Number:  0\nSample Number, Seconds, CHANNEL0, CHANNEL1\n"
                   + "\n".join(rows) + "\n")
    return src


def test_volts_are_never_read_as_metres_or_newtons(tmp_path):
    """A DAQ's channels mapped without a gain are refused in one line naming --gain (they
    read as 'sine 0.3 mm 333 Hz' before); with the gains they import."""
    from tests.test_hostile_inputs import one_line_error
    t, x, F = crank(rate=1000.0, n=3000)
    src = _daq(tmp_path, t, x, F)
    base = ("import", src, "--map", "time=Seconds", "--out", tmp_path / "d.mcap")
    one_line_error(dyno(*base, "--map", "displacement=CHANNEL0", "--map", "force=CHANNEL1:N", "--gain",
                        "force=980.665"),
                   "column 'CHANNEL0' (displacement) reads volts (a DAQ's channel, every value within +-10 V",
                   "--gain displacement=NUMBER")
    one_line_error(dyno(*base, "--map", "displacement=CHANNEL0:mm", "--gain", "displacement=10", "--map",
                        "force=CHANNEL1"), "column 'CHANNEL1' (force) reads volts", "--gain force=NUMBER")
    r = dyno(*base, "--map", "displacement=CHANNEL0:mm", "--gain", "displacement=10", "--offset",
             "displacement=49.5", "--map", "force=CHANNEL1:N", "--gain", "force=980.665", "--offset", "force=-9.80665")
    assert r.returncode == 0, r.stderr
    force = load_recording(tmp_path / "d.mcap")[0]["force"][1]
    assert np.allclose(force, F, atol=0.01)


def test_inspect_keeps_the_map_given_prefers_engineering_units_and_sees_centimetres(tmp_path):
    t = np.arange(0, 4, 1e-3)
    x = 0.9 * np.sin(2 * np.pi * 1.5 * t) + 0.1 * np.sin(2 * np.pi * 7 * t)  # cm, as the NEES white-noise file
    v = np.gradient(x, t)
    F = 900 * v / 100
    src = tmp_path / "cm.csv"
    src.write_text('"t","D","V","Force (V)","Force (N)"\n' + "".join(
        f"{a:.5f},{b:.5f},{c:.4f},{d / 980.665:.6f},{d:.3f}\n" for a, b, c, d in zip(t, x, v, F)))
    r = dyno("import", src, "--inspect")
    assert ("--map 'time=t' --map 'displacement=D:cm' --map 'velocity=V:cm/s' --map 'force=Force (N):N'"
            in r.stdout), r.stdout
    # a map given is kept as given; the rest is guessed around it
    r = dyno("import", src, "--inspect", "--map", "force=Force (V):N", "--map", "displacement=D:mm")
    assert "--map 'force=Force (V):N' --map 'displacement=D:mm' --map 'time=t' --map 'velocity=V'" in r.stdout, r.stdout
    # a displacement whose span a metre allows keeps SI
    src.write_text("t,D,F\n" + "".join(f"{a:.5f},{b / 100:.6f},{d:.3f}\n" for a, b, d in zip(t, x, F)))
    assert "--map 'displacement=D' --map 'force=F'" in dyno("import", src, "--inspect").stdout


PSI = 6894.757  # Pa


def _charged(psi, seed):
    """(t, x [m], F [N], its gas force at mid-stroke [N]): the thesis model's Koni charged to
    psi (gauge) on a 300 Hz crank-style dyno, 12.5 mm at 1 Hz, a load cell's 3 N of noise."""
    from dataclasses import replace
    from models.damper import load
    from models.physics.simulate import simulate
    d = load("koni")
    d = replace(d, gas_spring=replace(d.gas_spring, P0=101325.0 + psi * PSI))
    t = np.arange(0, 8, 1 / 300)
    x = d.mid_stroke + 0.0125 * np.sin(2 * np.pi * t)
    F = simulate(d, t, x, np.gradient(x, t), T=293.15, compressible=True, x_e=d.mid_stroke).force
    ts = np.arange(0, 20, 1e-3)  # at rest: a 0.1 mm stroke at 0.05 Hz
    xs = d.mid_stroke + 1e-4 * np.sin(2 * np.pi * 0.05 * ts)
    rest = simulate(d, ts, xs, np.gradient(xs, ts), T=293.15, compressible=False, x_e=d.mid_stroke).force.mean()
    return t, x, F + np.random.default_rng(seed).normal(0, 3.0, len(t)), float(rest)


def _lab_file(tmp_path, name, t, x, F):
    src = tmp_path / name
    src.write_text("t,x,F\n" + "".join(f"{a:.5f},{1e3 * b:.4f},{c:.2f}\n" for a, b, c in zip(t, x, F)))
    return src


MAP = ("--map", "time=t", "--map", "displacement=x:mm", "--map", "force=F")


def test_one_rigs_runs_get_one_right_flip_and_the_gas_force_with_its_interval(tmp_path):
    """Issue 89: one damper at 50 and 150 psi, its displacement counted from the other end
    (the force right): each import advises --flip displacement alone (the mean force, -83
    and +39 N, said the opposite); at 0 psi nothing tells which channel, and it is said.
    Read right, the comparison gives each gas force and the rise with their intervals,
    which hold the model's; both channels reversed, the gas force is said below zero."""
    truth = {}
    for psi in (50, 150):
        t, x, F, truth[psi] = _charged(psi, psi)
        src = _lab_file(tmp_path, f"{psi}.csv", t, 0.1 - x, F)
        r = dyno("import", src, *MAP, "--out", tmp_path / f"raw{psi}.mcap")
        said = next(line for line in r.stdout.splitlines() if line.startswith("sign: "))
        assert "import it again with --flip displacement:" in said and "--flip force" not in said, said
        r = dyno("import", src, *MAP, "--flip", "displacement", "--setup", f"gas_psi={psi}", "--serial", "K1",
                 "--out", tmp_path / f"{psi}.mcap")
        gas = next(line for line in r.stdout.splitlines() if line.startswith("gas force: "))
        level, hw = (float(v) for v in gas.split()[2:5:2])
        assert abs(level - truth[psi]) < hw < 20, (gas, truth[psi])
    t, x, F, rest = _charged(0, 7)
    r = dyno("import", _lab_file(tmp_path, "0.csv", t, 0.1 - x, F), *MAP, "--out", tmp_path / "raw0.mcap")
    said = next(line for line in r.stdout.splitlines() if line.startswith("sign: "))
    assert "cannot tell which channel" in said and "a static push" in said and "--flip displacement:" not in said, said
    r = dyno("import", _lab_file(tmp_path, "hot.csv", t, 0.1 - x, -F - 60.0), *MAP, "--out", tmp_path / "hot.mcap")
    assert "sign: " not in r.stdout and "below zero beyond its interval" in r.stdout, r.stdout
    r = dyno("report", tmp_path / "150.mcap", tmp_path / "50.mcap", "--out", tmp_path / "cmp")
    assert r.returncode == 0, r.stderr
    page = (tmp_path / "cmp" / "index.html").read_text().replace("&#39;", "'")
    said = page.split("against the gas charge: ")[1].split("</")[0]
    rise = float(said.split("it rises with the charge (")[1].split()[0])
    hw = float(said.split("it rises with the charge (")[1].split()[2])
    assert abs(rise - (truth[150] - truth[50])) < hw < 30, said
    step = said.split("over the same test, the mean force: ")[1].split()
    assert abs(float(step[0]) - (truth[150] - truth[50])) < max(float(step[2].rstrip(";")), 3.0), said


def test_the_gas_force_held_at_rest_from_holds_come_into_both_ways(tmp_path):
    """Issue 89, item 1: a static program (holds at mid-stroke and 8 mm either side, each
    come into by compression and by extension) on the thesis model's Koni at 100 psi, the
    seal holding +-25 N of friction in the direction the rod came: the gas force at rest is
    read with friction cancelled and its interval holds the model's; holds come into from
    one side only leave it said unknown."""
    from models.damper import load
    from models.physics.simulate import simulate
    d = load("koni")
    from dataclasses import replace
    d = replace(d, gas_spring=replace(d.gas_spring, P0=101325.0 + 100 * PSI))
    m, h = d.mid_stroke, 1e-3
    path = [(0.0, 1.0)]  # (offset [m], hold [s]) after a 0.2 s move
    for dx in (0.008, 0.0, -0.008, 0.0, 0.008, -0.008, 0.0):
        path.append((dx, 2.5))
    t, x, came = [np.arange(0, 1.0, h)], [np.full(1000, m)], [np.zeros(1000)]
    at = 0.0
    for (a, _), (b, hold) in zip(path, path[1:]):
        u = np.arange(0, 0.2, h)
        t += [t[-1][-1] + h + u, t[-1][-1] + h + 0.2 + np.arange(0, hold, h)]
        x += [m + a + (b - a) * 0.5 * (1 - np.cos(np.pi * u / 0.2)), np.full(int(round(hold / h)), m + b)]
        came += [np.zeros(len(u)), np.full(int(round(hold / h)), np.sign(b - a))]
        at = b
    t, x, came = np.concatenate(t), np.concatenate(x), np.concatenate(came)
    assert at == 0.0
    F = simulate(d, t, x, np.gradient(x, t), T=293.15, compressible=False, x_e=m).force + 25.0 * came
    F += np.random.default_rng(3).normal(0, 3.0, len(t))
    ts = np.arange(0, 20, 1e-3)
    xs = m + 1e-4 * np.sin(2 * np.pi * 0.05 * ts)
    truth = simulate(d, ts, xs, np.gradient(xs, ts), T=293.15, compressible=False, x_e=m).force.mean()
    r = dyno("import", _lab_file(tmp_path, "static.csv", t, x, F), *MAP, "--out", tmp_path / "static.mcap")
    assert r.returncode == 0, r.stderr
    said = next(line for line in r.stdout.splitlines() if line.startswith("gas force at rest: "))
    level, hw = (float(v) for v in said.split()[4:7:2])
    assert abs(level - truth) < hw < 15 and "from 7 holds come into from both directions" in said, (said, truth)
    # the first hold, at the file's start, was come into from no side: the report's static figures leave it out
    r = dyno("report", tmp_path / "static.mcap", "--out", tmp_path / "rep")
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr
    one_way = came >= 0
    r = dyno("import", _lab_file(tmp_path, "one.csv", t[one_way], x[one_way], F[one_way]), *MAP,
             "--out", tmp_path / "one.mcap")
    said = next(line for line in r.stdout.splitlines() if line.startswith("gas force at rest: "))
    assert said.startswith("gas force at rest: unknown") and "one direction" in said, said


def test_a_sheet_a_lab_signs(tmp_path):
    """Issue 89, item 6: a heat-gun run of the Koni model on a crank-style dyno (one speed,
    read along the stroke, its force 2 %-gained and flipped by the lab, temperature rising to
    83.5 C) and a gas-charge sweep. Page 1 names what was done to the data and the
    temperature's range, each velocity-table force its loop's half-width; the sweep is
    shown as the change per unit of the charge, no pass/fail until a tolerance is given; no
    printed page holds fewer than a dozen words."""
    from tests import pdf_pages
    t, x, F, _ = _charged(100, 5)
    T = 20.0 + 63.5 * t / t[-1]  # C
    src = tmp_path / "hot.csv"
    src.write_text("t,x,F,T\n" + "".join(f"{a:.5f},{1e3 * b:.4f},{-c / 1.02:.2f},{d:.2f}\n"
                                          for a, b, c, d in zip(t, x, F, T)))
    r = dyno("import", src, *MAP, "--map", "temperature=T:C", "--gain", "force=1.02", "--flip", "force",
             "--out", tmp_path / "hot.mcap")
    assert r.returncode == 0, r.stderr
    r = dyno("report", tmp_path / "hot.mcap", "--out", tmp_path / "rep")
    assert r.returncode == 0, r.stderr
    texts, _ = pdf_pages.text_and_sizes(tmp_path / "rep" / "report.pdf")
    one = " ".join(texts[0].split())
    assert "source data force flipped at import; gain force=1.02 at import; read in mm, C body" in one, one
    assert "20.0 C at the start, 83.5 at the end; 20.0 to 83.5 over the run" in one, one
    assert "at the turning points (friction cancelled, 95 %)" in one, one
    table = [ln.split(",") for ln in (tmp_path / "rep" / "velocity.csv").read_text().splitlines()]
    assert table[0][-2:] == ["W_comp_N", "W_reb_N"], table[0]
    row = next(r for r in table[1:] if r[0] == "25")
    assert float(row[5]) > 0 and float(row[6]) > 0  # the loop opens: the oil's compliance, the seal's friction
    assert f"{float(row[1]):.3g} ± {float(row[5]):.2g}" in one and "its loop's mid-line" in one, one
    assert min(len(p.split()) for p in texts) >= 12, [len(p.split()) for p in texts]
    for psi in (50, 100, 150):
        t, x, F, _ = _charged(psi, psi)
        assert dyno("import", _lab_file(tmp_path, f"{psi}.csv", t, x, F), *MAP, "--setup", f"gas_psi={psi}",
                    "--serial", "K1", "--out", tmp_path / f"{psi}.mcap").returncode == 0
    runs = [tmp_path / f"{psi}.mcap" for psi in (50, 100, 150)]
    assert dyno("report", *runs, "--out", tmp_path / "sweep").returncode == 0
    texts, _ = pdf_pages.text_and_sizes(tmp_path / "sweep" / "report.pdf")
    one = " ".join(texts[0].split())
    assert one.count("SWEEP: gas_psi") == 3 and "FAIL" not in one and "PASS" not in one, one
    assert "comp per gas_psi" in one and "change per unit of gas_psi" in one, one
    assert min(len(p.split()) for p in texts) >= 12, [len(p.split()) for p in texts]
    assert dyno("report", *runs, "--out", tmp_path / "judged", "--tolerance", "5%").returncode == 0
    judged = (tmp_path / "judged" / "index.html").read_text()
    assert "SWEEP" not in judged and judged.count("PASS: ") + judged.count("FAIL: ") == 2


def test_static_holds_pair_only_the_approaches_known():
    """A program's first hold has no side it was come into from ("unknown"): the static
    reading pairs each position's compression and extension holds and leaves it out (it
    was a KeyError where the unknown hold shared a position with one known side)."""
    from models.identify.static import static_holds
    from records import segmentation
    h, path = 1e-3, [(0.005, 1.5), (0.010, 1.5), (0.015, 1.5), (0.010, 1.5), (0.005, 1.5)]  # (x [m], hold [s])
    t, x = [np.arange(0, path[0][1], h)], [np.full(int(path[0][1] / h), path[0][0])]
    for (a, _), (b, hold) in zip(path, path[1:]):
        u = np.arange(0, 0.2, h)
        t += [t[-1][-1] + h + u, t[-1][-1] + h + 0.2 + np.arange(0, hold, h)]
        x += [a + (b - a) * 0.5 * (1 - np.cos(np.pi * u / 0.2)), np.full(int(round(hold / h)), b)]
    t, x = np.concatenate(t), np.concatenate(x)
    F = 200.0 + 4000.0 * x  # N: a gas spring's rise, no friction
    found = segmentation.find(t, x)
    approaches = [s.params.get("approach") for s in found if s.kind == "hold"]
    assert approaches == ["unknown", "compression stroke", "compression stroke", "extension stroke",
                          "extension stroke"], approaches
    xs, up, down = static_holds({"force": (t, F), "x": (t, x)}, segmentation.events(found))
    assert np.allclose(xs, [0.010]) and np.allclose(up, down) and np.allclose(up, 240.0), (xs, up, down)


def test_values_no_sensor_gives_leave_the_sign_unknown_not_a_traceback():
    """A fuzzed table's 1e308s overflowed the gas spring's cubic fit (LinAlgError: SVD did not
    converge) in `dyno import --inspect`: the sign is then not told from them."""
    from records.data import flips
    x = np.array([0.0, 1.7e308, -1.7e308, 3.0, 1e300, -5.0])
    F = np.array([1e308, -1e308, 1.0, 1e307, -1e308, 2.0])
    assert flips(x, F) is None
