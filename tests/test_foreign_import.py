"""Issue 43: recordings from other dynos and acquisition systems, written here in each
format they come in, imported as one of ours: date-time stamps, a DAQ's preamble and
volts, a decimal comma, tabs, whitespace without a header, Parquet, MATLAB, and the other
sign convention."""
import html
import json
import math
import warnings
from pathlib import Path
from datetime import datetime, timedelta, timezone

import numpy as np
import pytest

from records.reader import load_recording
from tests.conftest import dyno
from tests.test_hostile_inputs import one_line_error

RATE = 300.0  # Hz: the student crank dyno's
START = datetime(2025, 11, 14, 20, 14, 37, 917152, tzinfo=timezone.utc)


def crank(n=900, rate=RATE, stroke=0.038, rod=0.12, hz=1.05):
    """(t [s], x [m from full extension], F [N]): a slider-crank's stroke (not a sine: the
    rod's angle skews it) on a damper with gas force, valves and a little friction."""
    t = np.arange(n) / rate
    r = stroke / 2
    th = 2 * np.pi * hz * t
    x = 0.03 + r * (1 - np.cos(th)) + (r * r / (2 * rod)) * np.sin(th) ** 2
    v = np.gradient(x, t)
    F = 150 + 800 * x + np.where(v > 0, 2500 * v, 4200 * v) + 30 * np.tanh(v / 0.01)
    return t, x, F


def _stamps(t, fmt):
    return [(START + timedelta(seconds=float(s))).strftime(fmt) for s in t]


def _written(tmp_path, name, text, codec="utf-8"):
    p = tmp_path / name
    p.write_bytes(text.encode(codec))
    return p


def _imported(tmp_path, src, *args):
    out = tmp_path / "x.mcap"
    r = dyno("import", src, "--out", out, *args)
    assert r.returncode == 0, r.stderr
    channels, events, meta = load_recording(out)
    return channels, meta, r


def _same_motion(channels, t, x, F, tol_x=1e-6, tol_F=1e-3):
    tt, xx = channels["x"]
    assert len(tt) == len(t) and np.allclose(tt, t - t[0], atol=2e-6)
    assert np.allclose(xx, x, atol=tol_x) and np.allclose(channels["force"][1], F, atol=tol_F)


@pytest.mark.parametrize("fmt, zone, shift", [
    ("%Y-%m-%d %H:%M:%S.%f", "", 0.0),
    ("%Y-%m-%dT%H:%M:%S.%f", "Z", 0.0),
    ("%Y-%m-%dT%H:%M:%S.%f", "+01:00", -3600.0),
    ("%m/%d/%Y %I:%M:%S.%f %p", "", 0.0),
    ("%d.%m.%Y %H:%M:%S.%f", "", 0.0),  # a German DAQ's
    ("%d/%m/%Y %H:%M:%S.%f", "", 0.0),  # day first: the 14th says so
    ("%Y/%m/%d %H:%M:%S.%f", "", 0.0),
])
def test_date_time_stamps_give_the_time_and_the_recordings_start(tmp_path, fmt, zone, shift):
    t, x, F = crank()
    stamps = [s + zone for s in _stamps(t, fmt)]
    src = _written(tmp_path, "crank.csv", "time,pos_mm,load_N\n" + "".join(
        f"{s},{1e3 * a:.6f},{b:.4f}\n" for s, a, b in zip(stamps, x, F)))
    channels, meta, _ = _imported(tmp_path, src, "--map", "time=time", "--map", "displacement=pos_mm:mm",
                                  "--map", "force=load_N:N")
    _same_motion(channels, t, x, F)
    started = datetime.fromisoformat(meta["run"]["wall_start"])
    assert abs((started - START).total_seconds() - shift) < 1e-3
    assert meta["run"]["wall_start_source"] == "the file's first date-time stamp"


def test_stamps_of_whole_seconds_take_the_time_from_the_rate(tmp_path):
    """A logger that stamps whole seconds, its rate in the preamble: the time from the rate,
    the start from the first stamp; without a rate, or with one the stamps contradict, one
    line (a time that stood still broke the segmentation with a traceback)."""
    t, x, F = crank()
    whole = [(START.replace(microsecond=0) + timedelta(seconds=int(s))).strftime("%Y-%m-%d %H:%M:%S") for s in t]
    body = "Stamp,x [mm],F [N]\n" + "".join(f"{s},{1e3 * a:.6f},{b:.4f}\n" for s, a, b in zip(whole, x, F))
    args = ["--map", "time=Stamp", "--map", "displacement=x [mm]", "--map", "force=F [N]"]
    channels, meta, r = _imported(tmp_path, _written(tmp_path, "rate.csv", f"Sample rate: {RATE:g} Hz\n" + body), *args)
    _same_motion(channels, t, x, F)
    assert meta["run"]["wall_start"].startswith("2025-11-14T20:14:37.000")
    assert "time: the stamps advance only every 1 s (300 rows share each): the time is from the sampling rate, " \
           "300 Hz, the start from the first stamp" in r.stdout, r.stdout
    bare = _written(tmp_path, "bare.csv", body)
    one_line_error(dyno("import", bare, "--out", tmp_path / "b.mcap", *args),
                   "its date-time stamps repeat (300 rows share each, a stamp every 1 s): give the sampling rate")
    one_line_error(dyno("import", bare, "--out", tmp_path / "b.mcap", *args, "--rate", "100"),
                   "900 rows at 100 Hz span 8.99 s, the stamps 2 s: check the sampling rate")
    from records import segmentation
    assert segmentation.find(np.zeros(len(t)), x) == []


def test_a_zone_after_zone_less_stamps_is_applied_not_warned_about():
    from records.table import stamps
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # numpy's parser would warn and apply the zone itself
        t, bad = stamps(["2026-01-01T00:00:00", "2026-01-01T02:00:01+02:00", "2026-01-01 00:00:02"])
    assert bad is None and list(t - t[0]) == [0.0, 1.0, 2.0]


def test_stamps_that_cannot_tell_the_day_from_the_month_or_give_no_date(tmp_path):
    from records import csv_import, table
    # past midnight, the reading whose dates lie a day apart, not a month
    assert table.day_first(["03/05/2022 23:59:59", "04/05/2022 00:00:01"]) is True
    assert table.day_first(["05/03/2022 23:59:59", "05/04/2022 00:00:01"]) is False
    src = _written(tmp_path, "ambiguous.csv", "time;x;F\n" + "".join(
        f"03/05/2022 10:00:{i:02d},5;{i % 7};{i % 5}\n" for i in range(20)))
    got = csv_import.read(src, [("time", "time", "s"), ("displacement", "x", "mm"), ("force", "F", "N")])
    assert "cannot tell the day from the month" in got.time_note and "03/05/2022 as MM/DD/YYYY" in got.time_note
    assert got.start_epoch == datetime(2022, 3, 5, 10, 0, 0, 500000, tzinfo=timezone.utc).timestamp()
    # the time of day alone: no date, and a day added past midnight
    t, bad = table.stamps(["23:59:59.5", "11:59:59.75 PM", "00:00:00.25"])
    assert bad is None and list(t - t[0]) == [0.0, 0.25, 0.75] and not table.dated(["23:59:59.5"])
    clock = _written(tmp_path, "clock.csv", "time,x,F\n" + "".join(f"12:00:{i:02d}.000,{i % 7},{i % 5}\n"
                                                                    for i in range(20)))
    got = csv_import.read(clock, [("time", "time", "s"), ("displacement", "x", "mm"), ("force", "F", "N")])
    assert got.start_epoch is None and got.data["time"][-1] == 19.0
    # the date in a column of its own beside the time of day (a logger's Date, Time): the start, past midnight too
    both = _written(tmp_path, "both.csv", "Date,Time,x,F\n" + "".join(
        (f"14/11/2025,23:59:{50 + i}.5" if i < 10 else f"15/11/2025,00:00:{i - 10:02d}.5") + f",{i % 7},{i % 5}\n"
        for i in range(20)))
    got = csv_import.read(both, [("time", "Time", "s"), ("displacement", "x", "mm"), ("force", "F", "N")])
    assert got.start_epoch == datetime(2025, 11, 14, 23, 59, 50, 500000, tzinfo=timezone.utc).timestamp()
    assert got.data["time"][-1] == 19.0


def test_a_row_of_units_under_the_names_and_a_start_in_the_preamble(tmp_path):
    """As Dewesoft, DIAdem or imc write it: names, then their units on the next line, a
    time of numbers counted from the preamble's `Start time`."""
    t, x, F = crank()
    src = _written(tmp_path, "dewe.txt", "Data export\nStart time: 14.11.2025 20:14:37,917152\n\n"
                   "Time\tAI 1/Disp\tAI 2/Load\n[s]\t[mm]\t[kN]\n" + "".join(
                       f"{a + 2:.6f}\t{1e3 * b:.6f}\t{c / 1e3:.7f}\n" for a, b, c in zip(t, x, F)))
    r = dyno("import", src, "--inspect")
    assert "header on line 4 (units on line 5), data from line 6, 2 preamble lines" in r.stdout, r.stdout
    assert "--map 'displacement=AI 1/Disp [mm]:mm' --map 'force=AI 2/Load [kN]:kN'" in r.stdout, r.stdout
    assert "raw volts" not in r.stdout, r.stdout
    channels, meta, _ = _imported(tmp_path, src, "--map", "time=Time [s]:s", "--map", "displacement=AI 1/Disp [mm]:mm",
                                  "--map", "force=AI 2/Load [kN]:kN")
    _same_motion(channels, t, x, F, tol_F=0.1)
    assert meta["run"]["wall_start_source"] == "the start the file's preamble gives"
    assert abs((datetime.fromisoformat(meta["run"]["wall_start"]) - START).total_seconds() - 2.0) < 1e-3
    # a colon in a name, which --map reads as the unit's: mapped by position
    colon = _written(tmp_path, "colon.txt", "Time: s\tPosition: mm\tLoad: N\n" + "".join(
        f"{a:.5f}\t{1e3 * b:.4f}\t{c:.3f}\n" for a, b, c in zip(t, x, F)))
    assert "--map 'time=1:s' --map 'displacement=2:mm' --map 'force=3:N'" in dyno("import", colon, "--inspect").stdout
    # names alone, with a line above them: not a row of units
    from records.table import sniff
    assert sniff("a,b,c\nt,x,F\n0,1,2\n1,2,3\n").units is None


def test_an_imperial_export_its_units_as_written_and_its_date_and_time_on_two_lines(tmp_path):
    """As a US shock dyno writes it: inches, in/sec, lbs and F in the names, the test's date
    and time on two preamble lines. The map needs no units: the names give them."""
    t, x, F = crank()
    src = _written(tmp_path, "us.csv", "Shock Dyno Export\nDate,11/14/2025\nTime,20:14:37\nStroke (in),1.5\n\n"
                   "Time (sec),Position (in),Velocity (in/sec),Force (lbs),Temp (°F)\n" + "".join(
                       f"{a:.6f},{b / 0.0254:.7f},{v / 0.0254:.5f},{c / 4.4482216:.5f},{77 + a:.2f}\n"
                       for a, b, v, c in zip(t, x, np.gradient(x, t), F))
                   + "\nSummary\nMax Force (lbs),345.2\nMin Force (lbs),-330.1\n", "latin-1")
    r = dyno("import", src, "--inspect")
    assert "--map 'time=Time (sec):s' --map 'displacement=Position (in):in' --map 'velocity=Velocity (in/sec):in/s' " \
           "--map 'force=Force (lbs):lbf' --map 'temperature=Temp (°F):F'" in r.stdout, r.stdout
    channels, meta, r = _imported(tmp_path, src, "--map", "time=Time (sec)", "--map", "displacement=Position (in)",
                                  "--map", "force=Force (lbs)", "--map", "temperature=Temp (°F)")
    assert "units from the columns' names: displacement [in], force [lbf], temperature [F]" in r.stdout, r.stdout
    assert "after the data, left out: 3 lines that are no row of it ('Summary'; 'Max Force (lbs),345.2'; " \
           "'Min Force (lbs),-330.1')" in r.stdout, r.stdout
    _same_motion(channels, t, x, F, tol_x=1e-8, tol_F=1e-3)
    assert np.allclose(channels["T_body"][1], 273.15 + (77 + t - 32) * 5 / 9, atol=0.01)
    assert meta["run"]["wall_start_source"] == "the start the file's preamble gives"
    assert meta["run"]["wall_start"].startswith("2025-11-14T20:14:37")
    # a map copied from another file: its unit is read, and the name's is said beside it
    _, meta, r = _imported(tmp_path, src, "--map", "time=1", "--map", "displacement=2:mm", "--map", "force=4:lbf",
                           "--overwrite")
    said = "displacement: its column 'Position (in)' says in, read as mm as the map says"
    assert said in r.stdout and said in meta["run"]["import_notes"] and "force: its column" not in r.stdout, r.stdout
    # the units as a user spells them after the column, and one import does not know
    channels, _, _ = _imported(tmp_path, src, "--map", "time=1:sec", "--map", "displacement=2:inch", "--map",
                               "force=4:LBS", "--overwrite")
    _same_motion(channels, t, x, F, tol_x=1e-8, tol_F=1e-3)
    one_line_error(dyno("import", src, "--out", tmp_path / "y.mcap", "--map", "displacement=2", "--map", "force=4:lbz"),
                   "--map force=4:lbz: unknown force unit 'lbz' (known: N, kN, daN, lbf, kgf)")
    # a raw channel's volts mapped without a gain: refused, naming the gain (issue 89)
    volts = _written(tmp_path, "volts.csv", src.read_text("latin-1").replace("Force (lbs)", "Load cell (V)"))
    one_line_error(dyno("import", volts, "--map", "displacement=Position (in)", "--map", "force=Load cell (V)",
                        "--map", "time=1", "--out", tmp_path / "v.mcap"),
                   "column 'Load cell (V)' (force) reads volts (its name says V): give its gain into N, "
                   "--gain force=NUMBER (per volt)")
    _, _, r = _imported(tmp_path, volts, "--map", "displacement=Position (in)", "--map", "force=Load cell (V)",
                        "--map", "time=1", "--gain", "force=4.448", "--overwrite")
    assert "force: its column" not in r.stdout


def test_a_daq_export_with_a_preamble_us_stamps_volts_and_an_events_column(tmp_path):
    """As the UTFSM press's acquisition wrote it: 7 preamble lines, `Sample Number,
    Date/Time, CHANNEL0, CHANNEL1, Events`, US stamps, volts with their offsets."""
    t, x, F = crank(rate=1000.0, n=3000)
    rows = [f"{i + 1:>10},   {s}, {(x[i] - 0.0495) / 0.01:.5f}, {F[i] / 980.665 + 0.01:.6f}"
            + (", DAQ Start" if i == 0 else "") for i, s in enumerate(_stamps(t, "%m/%d/%Y %I:%M:%S.%f %p"))]
    text = ("Header Size:  7\r\nVersion:  2\r\nSampling Interval:  0.001\r\nSampling Rate:  1000\r\n"
            "Sample Count:  3000\r\nDevice Serial Number:  0\r\nSample Number, Date/Time, CHANNEL0, CHANNEL1, Events\r\n"
            + "\r\n".join(rows) + "\r\n")
    src = _written(tmp_path, "daq.txt", text)
    r = dyno("import", src, "--inspect")
    assert r.returncode == 0 and "header on line 7" in r.stdout and "sampling rate 1000 Hz" in r.stdout, r.stdout
    assert "--map 'time=Date/Time'" in r.stdout and not list(tmp_path.glob("*.mcap"))
    # the volts by their values: the displacement is the smoothest, the force follows its rate of change
    assert "guessed from the values (check the units): --map 'displacement=CHANNEL0' --map 'force=CHANNEL1'" \
        in r.stdout and "counting the rows, no channel: 1 (Sample Number)" in r.stdout, r.stdout
    assert "not guessed" not in r.stdout, r.stdout
    # a second load cell beside the first: which one is the force the values cannot tell
    head = text.split("Sample Number")[0] + "Sample Number, Date/Time, CHANNEL0, CHANNEL1, CHANNEL2, Events\r\n"
    two = _written(tmp_path, "two.txt", head + "".join(
        f"{i + 1:>10},   {st}, {(x[i] - 0.0495) / 0.01:.5f}, {F[i] / 980.665:.6f}, {F[i] / 490.3:.6f}\r\n"
        for i, st in enumerate(_stamps(t, "%m/%d/%Y %I:%M:%S.%f %p"))))
    r = dyno("import", two, "--inspect")
    assert "the force is CHANNEL1 or CHANNEL2, which follow its rate of change alike" in r.stdout, r.stdout
    # a load cell wired tension positive: still the force, and the flip is said
    tension = _written(tmp_path, "tension.txt", head.replace(", CHANNEL2", "") + "".join(
        f"{i + 1:>10},   {st}, {(x[i] - 0.0495) / 0.01:.5f}, {-F[i] / 980.665:.6f}\r\n"
        for i, st in enumerate(_stamps(t, "%m/%d/%Y %I:%M:%S.%f %p"))))
    r = dyno("import", tension, "--inspect")
    assert "--map 'force=CHANNEL1'" in r.stdout and "(correlation -0." in r.stdout, r.stdout
    assert "sign: with this map the damper would give energy back" in r.stdout and "add --flip force" in r.stdout
    # volts about the LVDT's zero: below zero, which from full extension a displacement cannot be
    _, _, r = _imported(tmp_path, src, "--map", "time=Date/Time", "--map", "displacement=CHANNEL0:mm",
                        "--gain", "displacement=10", "--map", "force=CHANNEL1:N", "--gain", "force=980.665")
    said = [line for line in r.stdout.splitlines() if line.startswith("displacement: it reads")]
    low = float(said[0].split("--offset displacement=")[1].split()[0]) if said else None
    assert low is not None and abs(low - 1e3 * (0.0495 - x.min())) < 1e-3, r.stdout
    channels, meta, _ = _imported(tmp_path, src, "--map", "time=Date/Time", "--map", "displacement=CHANNEL0:mm",
                                  "--overwrite",
                                  "--gain", "displacement=10", "--offset", "displacement=49.5",
                                  "--map", "force=CHANNEL1:N", "--gain", "force=980.665", "--offset", "force=-9.80665")
    _same_motion(channels, t, x, F, tol_x=1e-7, tol_F=1e-2)


def test_a_semicolon_file_with_decimal_commas_in_windows_encoding(tmp_path):
    t, x, F = crank()
    body = "".join(f"{a:.4f};{1e3 * b:.5f};{c:.3f};\n".replace(".", ",") for a, b, c in zip(t, x, F))
    src = _written(tmp_path, "de.csv", "Zeit [s];Weg [mm];Kraft [N];\n" + body, "latin-1")
    channels, _, _ = _imported(tmp_path, src, "--map", "time=Zeit [s]", "--map", "displacement=Weg [mm]:mm",
                               "--map", "force=Kraft [N]")
    _same_motion(channels, np.round(t, 4), np.round(x, 8), np.round(F, 3), tol_x=1e-8)
    r = dyno("import", src, "--inspect")
    assert "--map 'time=Zeit [s]:s' --map 'displacement=Weg [mm]:mm' --map 'force=Kraft [N]:N'" in r.stdout, r.stdout


def test_quoted_decimal_commas_and_a_time_counted_in_minutes_and_seconds(tmp_path):
    """An Excel CSV that quotes each cell, the comma both delimiter and decimal mark; a
    logger's elapsed time as mm:ss.fff."""
    t, x, F = crank()
    quoted = _written(tmp_path, "q.csv", '"Zeit [s]","Weg [mm]","Kraft [N]"\n' + "".join(
        f'"{a:.7f}","{1e3 * b:.6f}","{c:.4f}"\n'.replace(".", ",") for a, b, c in zip(t, x, F)))
    assert "comma-separated, decimal comma, header on line 1" in dyno("import", quoted, "--inspect").stdout
    channels, _, _ = _imported(tmp_path, quoted, "--map", "time=1", "--map", "displacement=2", "--map", "force=3")
    _same_motion(channels, t, x, F)
    minutes = _written(tmp_path, "m.csv", "Elapsed,x [mm],F [N]\n" + "".join(
        f"{int((a + 59) // 60):02d}:{(a + 59) % 60:09.6f},{1e3 * b:.6f},{c:.4f}\n" for a, b, c in zip(t, x, F)))
    channels, meta, _ = _imported(tmp_path, minutes, "--map", "time=Elapsed", "--map", "displacement=2", "--map",
                                  "force=3", "--overwrite")
    _same_motion(channels, t, x, F)
    assert meta["run"]["wall_start_source"] == meta["run"]["wall_start"] == "unknown"


def test_cells_a_spreadsheet_marks_missing_are_read_as_empty(tmp_path):
    t, x, F = crank()
    rows = [f"{a:.6f},{'#N/A' if i == 100 else f'{c:.4f}'},{'-' if i == 200 else f'{1e3 * b:.6f}'}\n"
            for i, (a, b, c) in enumerate(zip(t, x, F))]
    na = _written(tmp_path, "na.csv", "t,F,x\n" + "".join(rows))
    one_line_error(dyno("import", na, "--out", tmp_path / "n.mcap", "--map", "time=t", "--map", "displacement=x:mm",
                        "--map", "force=F"), "na.csv:102: column 'F' (force): 1 row with no number", "--allow-gaps")
    channels, _, r = _imported(tmp_path, na, "--map", "time=t", "--map", "displacement=x:mm", "--map", "force=F",
                               "--allow-gaps")
    assert len(channels["force"][0]) == len(t) - 1 and len(channels["x"][0]) == len(t) - 1
    assert "force: 1 of" in r.stdout and "(line 102)" in r.stdout and "(line 202)" in r.stdout, r.stdout
    assert np.allclose(channels["force"][1], np.delete(F, 100), atol=1e-3)
    one_line_error(dyno("import", _written(tmp_path, "bad.csv", "t,F,x\n" + "".join(rows).replace("#N/A", "#REF?")),
                        "--out", tmp_path / "b.mcap", "--map", "time=t", "--map", "displacement=x:mm", "--map", "force=F"),
                   "bad.csv:102: column 'F': '#REF?' is not a number")


def test_a_name_the_header_repeats_hides_no_column(tmp_path):
    """Two load cells both headed `Force`: each keeps its column (before, the second replaced
    the first, and a map by position read the wrong one)."""
    t, x, F = crank()
    src = _written(tmp_path, "two.csv", "Time,Force,Force,Position\n" + "".join(
        f"{a:.6f},{c:.4f},{2 * c:.4f},{1e3 * b:.6f}\n" for a, b, c in zip(t, x, F)))
    assert "   3  'Force #3'" in dyno("import", src, "--inspect").stdout
    # a header written as a comment: the mark is no part of the first name
    hashed = _written(tmp_path, "hash.csv", "# exported by RigLog\n" + src.read_text().replace("Time,", "# Time,", 1))
    assert "--map 'time=Time' --map 'force=Force'" in dyno("import", hashed, "--inspect").stdout
    channels, _, _ = _imported(tmp_path, src, "--map", "time=Time", "--map", "displacement=4:mm", "--map", "force=3")
    _same_motion(channels, t, x, 2 * F, tol_F=2e-3)
    channels, _, _ = _imported(tmp_path, src, "--map", "time=Time", "--map", "displacement=Position:mm",
                               "--map", "force=Force", "--overwrite")
    _same_motion(channels, t, x, F)


@pytest.mark.parametrize("names, expected", [
    (("Tiempo [s]", "Desplazamiento [mm]", "Velocidad [mm/s]", "Fuerza [kN]"), ("time:s", "displacement:mm",
                                                                             "velocity:mm/s", "force:kN")),
    (("Temps (s)", "Déplacement (mm)", "Vitesse (m/s)", "Effort (N)", "Température (C)"),
     ("time:s", "displacement:mm", "velocity:m/s", "force:N", "temperature:C")),
    (("Zeit", "Hub [mm]", "Geschw. [mm/s]", "Kraft [kN]", "Druck [bar]"),
     ("time", "displacement:mm", "velocity:mm/s", "force:kN", "pressure:bar")),
])
def test_column_names_in_the_languages_dyno_software_writes(names, expected):
    from records.column_guess import by_name
    assert tuple(by_name(n, None) for n in names) == expected


def test_tests_exported_one_after_another_each_from_time_zero(tmp_path):
    """A crank dyno's speeds, each test's time from 0: read as following on, each its segment;
    a time that goes back anywhere else is still refused."""
    parts = [crank(n=int(4 / hz * RATE), hz=hz) for hz in (0.5, 1.05, 2.1)]
    src = _written(tmp_path, "speeds.csv", "t,x,F\n" + "".join(f"{a:.5f},{1e3 * b:.4f},{c:.3f}\n"
                                                               for t, x, F in parts for a, b, c in zip(t, x, F)))
    channels, _, r = _imported(tmp_path, src, "--map", "time=t", "--map", "displacement=x:mm", "--map", "force=F")
    assert "time: it restarts 2 times from its first value (lines 2402, 3544)" in r.stdout, r.stdout
    assert ("segments: 100 % in 3 sines; sine 19 mm 0.5 Hz (4 cycles), sine 19 mm 1.05 Hz (4 cycles), "
            "sine 19 mm 2.1 Hz (4 cycles)") in r.stdout, r.stdout
    t = channels["x"][0]
    assert np.all(np.diff(t) > 0) and abs(t[-1] - (sum(len(p[0]) for p in parts) - 1) / RATE) < 1e-3
    from views.reports.recording import report  # said again to whoever reads the report later
    index, _ = report(tmp_path / "x.mcap", tmp_path / "report")
    assert "What the import said of the file:" in index.read_text() and "it restarts 2 times" in index.read_text()
    t, x, F = crank()
    t[600:] -= 1.0  # back to the middle: no restart
    bad = _written(tmp_path, "bad.csv", "t,x,F\n" + "".join(f"{a:.5f},{1e3 * b:.4f},{c:.3f}\n" for a, b, c in zip(t, x, F)))
    one_line_error(dyno("import", bad, "--out", tmp_path / "bad.mcap", "--map", "time=t", "--map",
                        "displacement=x:mm", "--map", "force=F"), "bad.csv:602: time goes backwards")
    # exports joined into one file, each with its preamble (a blank line in it), header and units line
    export = ["Dyno export\nShock: A-12\n\nt,x,F\ns,mm,N\n" + "".join(f"{a:.5f},{1e3 * b:.4f},{c:.3f}\n"
                                                                       for a, b, c in zip(*p)) for p in parts]
    joined = _written(tmp_path, "joined.csv", "".join(export) + "\n\n")
    channels, _, r = _imported(tmp_path, joined, "--map", "time=1", "--map", "displacement=2", "--map", "force=3",
                               "--overwrite")
    first = [6 + len(parts[0][0]) + 5, 6 + len(parts[0][0]) + 5 + len(parts[1][0]) + 5]  # each section's first row
    assert f"time: it restarts 2 times from its first value (lines {first[0]}, {first[1]})" in r.stdout, r.stdout
    assert len(channels["x"][0]) == sum(len(p[0]) for p in parts) and "in 3 sines" in r.stdout
    lines = joined.read_text().splitlines()
    assert lines[first[0] - 1].startswith("0.00000,") and lines[first[0] - 2] == "s,mm,N"


def test_tabs_and_milliseconds(tmp_path):
    t, x, F = crank()
    src = _written(tmp_path, "tab.txt", "t_ms\tx_in\tF_lbf\n" + "".join(
        f"{1e3 * a:.4f}\t{b / 0.0254:.8f}\t{c / 4.4482216:.6f}\n" for a, b, c in zip(t, x, F)))
    channels, _, _ = _imported(tmp_path, src, "--map", "time=t_ms:ms", "--map", "displacement=x_in:in",
                               "--map", "force=F_lbf:lbf")
    _same_motion(channels, t, x, F, tol_F=1e-2)
    # a time named without its unit, one row every 3.33: ms by its step (no dyno samples at 0.3 Hz)
    src = _written(tmp_path, "ms.txt", "Time\tx_in\tF_lbf\n" + "".join(
        f"{1e3 * a:.4f}\t{b / 0.0254:.8f}\t{c / 4.4482216:.6f}\n" for a, b, c in zip(t, x, F)))
    assert "--map 'time=Time:ms'" in dyno("import", src, "--inspect").stdout
    _, _, r = _imported(tmp_path, src, "--map", "time=Time", "--map", "displacement=x_in:in",
                        "--map", "force=F_lbf:lbf", "--overwrite")
    assert "time: one row every 3.33 s (0.3 Hz), read as seconds" in r.stdout, r.stdout


def test_whitespace_without_a_header_by_position_and_time_from_the_rate(tmp_path):
    t, x, F = crank()
    src = _written(tmp_path, "sine.txt", "".join(f"   {a:.7e}  {1e3 * b:.7e}  {c:.7e}\r\n" for a, b, c in zip(t, x, F)))
    channels, _, _ = _imported(tmp_path, src, "--map", "time=1", "--map", "displacement=2:mm", "--map", "force=3")
    _same_motion(channels, t, x, F)
    channels, meta, _ = _imported(tmp_path, src, "--map", "displacement=2:mm", "--map", "force=3", "--rate", "300",
                                  "--overwrite")
    _same_motion(channels, t, x, F)
    assert meta["run"]["time_source"] == "time from the sampling rate, 300 Hz"
    one_line_error(dyno("import", src, "--out", tmp_path / "y.mcap", "--map", "displacement=2:mm", "--map", "force=9"),
                   "no column '9'")


def test_parquet_and_matlab(tmp_path):
    import pyarrow as pa
    import pyarrow.parquet as pq
    from scipy.io import savemat
    t, x, F = crank()
    pq.write_table(pa.table({"time": t, "x_mm": 1e3 * x, "force": F}), tmp_path / "run.parquet")
    channels, _, _ = _imported(tmp_path, tmp_path / "run.parquet", "--map", "time=time", "--map",
                               "displacement=x_mm:mm", "--map", "force=force")
    _same_motion(channels, t, x, F)
    savemat(tmp_path / "run.mat", {"data": np.column_stack([t, 1e3 * x, F])})
    channels, _, _ = _imported(tmp_path, tmp_path / "run.mat", "--map", "time=data[1]", "--map",
                               "displacement=data[2]:mm", "--map", "force=data[3]", "--overwrite")
    _same_motion(channels, t, x, F)


def test_a_tdms_file_its_units_its_waveform_time_and_start(tmp_path):
    """As a LabVIEW or DIAdem cell writes it: channels with a unit_string and a waveform's
    timing; the names guess the whole map, the start is the waveform's."""
    from nptdms import ChannelObject, GroupObject, RootObject, TdmsWriter
    t, x, F = crank()
    wave = {"wf_increment": 1 / RATE, "wf_start_offset": 0.0,
            "wf_start_time": np.datetime64(START.replace(tzinfo=None), "us")}
    with TdmsWriter(tmp_path / "run.tdms") as w:
        w.write_segment([RootObject({"name": "A-12"}), GroupObject("Dyno"),
                         ChannelObject("Dyno", "LVDT", 1e3 * x, properties={"unit_string": "mm", **wave}),
                         ChannelObject("Dyno", "Load cell", F / 1e3, properties={"unit_string": "kN", **wave}),
                         ChannelObject("Dyno", "Oil temp", np.full(len(t), 41.0), properties={"unit_string": "°C",
                                                                                              **wave})])
    r = dyno("import", tmp_path / "run.tdms", "--inspect")
    assert "guessed map (check the units): --map 'time=Time' --map 'displacement=LVDT [mm]:mm' --map " \
           "'force=Load cell [kN]:kN' --map 'temperature=Oil temp [°C]:C'" in r.stdout, r.stdout
    channels, meta, _ = _imported(tmp_path, tmp_path / "run.tdms", "--map", "time=Time", "--map",
                                  "displacement=LVDT [mm]", "--map", "force=Load cell [kN]", "--map",
                                  "temperature=Oil temp [°C]")
    _same_motion(channels, t, x, F)
    assert np.allclose(channels["T_body"][1], 314.15)
    assert abs((datetime.fromisoformat(meta["run"]["wall_start"]) - START).total_seconds()) < 1e-5
    with TdmsWriter(tmp_path / "rates.tdms") as w:
        w.write_segment([ChannelObject("Fast", "x", x), ChannelObject("Slow", "T", np.full(10, 41.0))])
    one_line_error(dyno("import", tmp_path / "rates.tdms", "--inspect"), "its channels differ in length")
    (tmp_path / "text.tdms").write_text("t,x,F\n")
    one_line_error(dyno("import", tmp_path / "text.tdms", "--inspect"), "text.tdms: ")


def test_an_excel_workbook_its_fullest_sheet_with_a_preamble_units_and_stamps(tmp_path):
    import openpyxl
    t, x, F = crank(rate=1000.0, n=3000)  # Excel's stamps keep the millisecond
    book = openpyxl.Workbook()
    book.active.append(["Test sheet: shock 12, clicker 4"])
    data = book.create_sheet("Data")
    for row in (["Damper test"], ["Start time", START.replace(tzinfo=None)], [], ["Date/Time", "Position", "Load"],
                [None, "mm", "kN"]):
        data.append(row)
    for a, b, c in zip(t, x, F):
        data.append([(START + timedelta(seconds=float(a))).replace(tzinfo=None), 1e3 * b, c / 1e3])
    book.save(tmp_path / "run.xlsx")
    r = dyno("import", tmp_path / "run.xlsx", "--inspect")
    assert "run.xlsx: sheet 'Data', header on line 4 (units on line 5), data from line 6" in r.stdout, r.stdout
    assert "--map 'time=Date/Time' --map 'displacement=Position [mm]:mm' --map 'force=Load [kN]:kN'" in r.stdout
    channels, meta, _ = _imported(tmp_path, tmp_path / "run.xlsx", "--map", "time=Date/Time", "--map",
                                  "displacement=Position [mm]:mm", "--map", "force=Load [kN]:kN")
    _same_motion(channels, t, x, F)
    assert abs((datetime.fromisoformat(meta["run"]["wall_start"]) - START).total_seconds()) < 1e-3
    assert "sheets: 'Sheet', 'Data' (--sheet NAME reads another)" in r.stdout, r.stdout
    # another test on a sheet of its own, read by name
    fast = book.create_sheet("2.1 Hz")
    t2, x2, F2 = crank(n=400, hz=2.1)
    fast.append(["t [s]", "x [mm]", "F [N]"])
    for a, b, c in zip(t2, x2, F2):
        fast.append([float(a), 1e3 * b, c])
    book.save(tmp_path / "run.xlsx")
    channels, meta, _ = _imported(tmp_path, tmp_path / "run.xlsx", "--sheet", "2.1 Hz", "--map", "time=1", "--map",
                                  "displacement=2", "--map", "force=3", "--overwrite")
    _same_motion(channels, t2, x2, F2)
    assert json.loads(meta["protocol"]["params"])["sheet"] == "2.1 Hz"
    one_line_error(dyno("import", tmp_path / "run.xlsx", "--inspect", "--sheet", "3 Hz"),
                   "--sheet 3 Hz: no such sheet in run.xlsx; its sheets: 'Sheet', 'Data', '2.1 Hz'")
    (tmp_path / "old.xls").write_bytes(b"\xd0\xcf\x11\xe0")
    one_line_error(dyno("import", tmp_path / "old.xls", "--inspect"), "Excel 97-2003", "save it as .xlsx")
    (tmp_path / "bad.xlsx").write_text("not a zip")
    one_line_error(dyno("import", tmp_path / "bad.xlsx", "--inspect"), "not a readable Excel workbook")


def test_the_other_sign_convention_is_named_in_one_line_and_flipped(tmp_path):
    t, x, F = crank()
    src = _written(tmp_path, "tension.csv", "t,x,F\n" + "".join(f"{a},{1e3 * b},{-c}\n" for a, b, c in zip(t, x, F)))
    args = ["--map", "time=t", "--map", "displacement=x:mm", "--map", "force=F"]
    _, _, r = _imported(tmp_path, src, *args)
    said = [line for line in r.stdout.splitlines() if line.startswith("sign: ")]
    assert len(said) == 1 and "--flip force" in said[0] and "other sign convention" in said[0], r.stdout
    for command in (["identify", tmp_path / "x.mcap", "--damper", "koni", "--out", tmp_path / "m.json"],
                    ["diagnose", tmp_path / "x.mcap"], ["check", tmp_path / "x.mcap", "--against", "koni"]):
        one_line_error(dyno(*command), "other sign convention", "--flip force")
    from views.reports.recording import report  # drawn as it is, and said so above its tables
    index, _ = report(tmp_path / "x.mcap", tmp_path / "report")
    assert "Sign convention: the damper would give back" in index.read_text()
    r = dyno("import", src, "--inspect")
    assert "sign: with this map" in r.stdout and "add --flip force (the force at the turning points reads -" \
        in r.stdout and "--flip displacement" not in r.stdout, r.stdout
    channels, _, r = _imported(tmp_path, src, *args, "--flip", "force", "--overwrite")
    assert "sign: " not in r.stdout and np.allclose(channels["force"][1], F, atol=1e-6)
    # displacement measured from the other end: flipped about its most extended reading
    src = _written(tmp_path, "other-end.csv", "t,x,F\n" + "".join(f"{a},{1e3 * (0.1 - b)},{c}\n"
                                                                    for a, b, c in zip(t, x, F)))
    _, _, r = _imported(tmp_path, src, *args, "--overwrite")
    assert "import it again with --flip displacement: the force at the stroke's turning points" in r.stdout \
        and "--flip force" not in r.stdout, r.stdout
    channels, _, _ = _imported(tmp_path, src, *args, "--flip", "displacement", "--overwrite")
    assert np.allclose(np.diff(channels["x"][1]), np.diff(x), atol=1e-9)


@pytest.mark.parametrize("scale, flip, said", [
    (-1, [], "velocity: it falls as the displacement rises: the velocity is counted the other way from the "
                 "displacement (rebound positive); import it again with --flip velocity"),
    (-1, ["--flip", "velocity"], None),
    (1, [], None),
    (0.1, [], "velocity: the displacement changes 10 times as fast as the velocity says: check the velocity's "
                     "and the displacement's units"),
])
def test_a_velocity_that_is_not_the_displacements_rate_of_change_is_said(tmp_path, scale, flip, said):
    """An LVT wired rebound positive beside a displacement counted ours, or a velocity in
    another unit: the report would draw its force against velocity mirrored or stretched."""
    t, x, F = crank()
    v = np.gradient(x, t)
    src = _written(tmp_path, "v.csv", "t,x,v,F\n" + "".join(f"{a},{1e3 * b},{1e3 * scale * w},{c}\n"
                                                            for a, b, w, c in zip(t, x, v, F)))
    channels, meta, r = _imported(tmp_path, src, "--map", "time=t", "--map", "displacement=x:mm",
                                  "--map", "velocity=v:mm/s", "--map", "force=F", *flip)
    lines = [line for line in r.stdout.splitlines() if line.startswith("velocity:")]
    assert lines == ([said] if said else []), r.stdout
    assert (said or "") in meta["run"].get("import_notes", "")
    if flip:
        assert np.allclose(channels["v"][1], v, atol=1e-9)


def test_import_reads_a_million_rows(tmp_path):
    """The time goal is measured by `dyno bench import`; here only that a large file imports."""
    n = 200_000
    t = np.arange(n) / 1000.0
    src = tmp_path / "big.csv"
    np.savetxt(src, np.column_stack([t, 30 + 5 * np.sin(t), 100 * np.cos(t)]), delimiter=",", header="t,x,F",
               comments="", fmt="%.6f")
    channels, _, _ = _imported(tmp_path, src, "--map", "time=t", "--map", "displacement=x:mm", "--map", "force=F")
    assert len(channels["force"][0]) == n and math.isclose(channels["force"][0][-1], t[-1])


def test_a_crank_dynos_run_is_cut_into_its_stroke_and_reported(tmp_path):
    """The crank-dyno-like file of the issue: 300 Hz, date-time stamps, one stroke of 38 mm
    at 1.05 Hz for 30 cycles, then a hold: one sine segment named as ours are, its peaks in
    the report."""
    t, x, F = crank(n=int(30 / 1.05 * RATE))
    hold = np.arange(1, int(RATE)) / RATE + t[-1]
    t, x, F = np.concatenate([t, hold]), np.concatenate([x, np.full(len(hold), x[-1])]), \
        np.concatenate([F, np.full(len(hold), F[-1])])
    src = _written(tmp_path, "crank.csv", "Time,Position (mm),Force (N)\n" + "".join(
        f"{s},{1e3 * a:.4f},{b:.3f}\n" for s, a, b in zip(_stamps(t, "%Y-%m-%d %H:%M:%S.%f"), x, F)))
    r = dyno("import", src, "--inspect")
    assert "--map 'time=Time' --map 'displacement=Position (mm):mm' --map 'force=Force (N):N'" in r.stdout, r.stdout
    _, _, r = _imported(tmp_path, src, "--map", "time=Time", "--map", "displacement=Position (mm):mm",
                        "--map", "force=Force (N):N")
    assert "segments: 97 % in 1 sine, 3 % in 1 hold; sine 19 mm 1.05 Hz (30 cycles)" in r.stdout, r.stdout
    rep = dyno("report", tmp_path / "x.mcap", "--out", tmp_path / "rep")
    assert rep.returncode == 0, rep.stderr
    peaks = (tmp_path / "rep" / "peaks.csv").read_text().splitlines()
    row = peaks[1].split(",")
    assert len(peaks) == 2 and row[0] == "sine 19 mm 1.05 Hz" and abs(float(row[1]) - 19) < 0.01, peaks
    v_peak = float(row[6])  # mm/s: a crank's peak speed is near 2 pi f r
    assert abs(v_peak / (2 * np.pi * 1.05 * 19) - 1) < 0.05
    # one speed: the velocity table is read along the stroke, up to the top speed reached
    page = (tmp_path / "rep" / "index.html").read_text()
    assert "read along the stroke" in page and "Force against shaft speed along the stroke" in page
    table = {float(r.split(",")[0]): r.split(",")[1:3] for r in
             (tmp_path / "rep" / "velocity.csv").read_text().splitlines()[1:]}
    x_mid = 0.03 + 0.019  # m: the gas and spring force of the file's damper at mid-stroke
    for speed, comp, reb in ((25.0, 2500, 4200), (100.0, 2500, 4200)):
        expected = 150 + 800 * x_mid + np.array([comp, -reb]) * speed * 1e-3 + np.array([30, -30]) * np.tanh(speed / 10)
        assert np.allclose([float(f) for f in table[speed]], expected, atol=6), (speed, table[speed], expected)  # 1 % of the range
    assert table[150.0] == ["", ""]  # beyond the top speed: not extrapolated
    r = dyno("diagnose", tmp_path / "x.mcap", "--holdout", "tail:0.15")  # and a diagnosis, as ours get
    assert r.returncode == 0 and "Baseline (minimal): held-out error" in r.stdout, r.stdout + r.stderr


def test_a_load_cell_offset_the_file_kept_is_said_with_its_tare(tmp_path):
    """Raw volts whose zero was not removed: 600 N low, so the force at the compression peaks
    is below zero and the gas force at the turning points too, which no gas spring gives."""
    t, x, F = crank(n=int(12 / 1.05 * RATE))
    src = _written(tmp_path, "offset.csv", "t,x,F\n" + "".join(f"{a:.5f},{1e3 * b:.4f},{c - 600:.3f}\n"
                                                                for a, b, c in zip(t, x, F)))
    _imported(tmp_path, src, "--map", "time=t", "--map", "displacement=x:mm", "--map", "force=F")
    r = dyno("identify", tmp_path / "x.mcap")
    said = [line for line in r.stdout.splitlines() if line.startswith("note: the force at the stroke's turning")]
    assert r.returncode == 0 and len(said) == 1 and "a load cell's offset the file kept" in said[0], r.stdout
    low = float(said[0].split("reads at least ")[1].split(" N low")[0])
    assert abs(low - (600 - np.mean(150 + 800 * x))) < 30 and f"--offset force={low:.0f}" in said[0]
    from views.reports.recording import report
    index, _ = report(tmp_path / "x.mcap", tmp_path / "report")
    assert "compression peak (127 mm/s) the force reads -65" in index.read_text()


def test_identify_without_a_description_gives_the_minimal_model_judged_on_held_out_cycles(tmp_path):
    """A crank dyno's file names no damper: identify fits the model that needs none, says
    its held-out error and which parameters the recording could not determine."""
    t, x, F = crank(n=int(20 / 1.05 * RATE))
    F = F + np.random.default_rng(0).normal(0, 5.0, len(F))
    src = _written(tmp_path, "crank.csv", "t,x,F\n" + "".join(f"{a:.5f},{1e3 * b:.4f},{c:.3f}\n"
                                                               for a, b, c in zip(t, x, F)))
    _imported(tmp_path, src, "--map", "time=t", "--map", "displacement=x:mm", "--map", "force=F")
    r = dyno("identify", tmp_path / "x.mcap")
    assert r.returncode == 0, r.stderr
    doc = json.loads((tmp_path / "x.minimal.json").read_text())
    assert doc["model"] == "minimal" and doc["heldout_nrmse"] < 0.05 and doc["heldout_r2"] > 0.99
    assert abs(doc["parameters"]["G0"]["value"] - np.mean(150 + 800 * x)) < 20  # the gas force at mid-stroke
    assert all(("undetermined" in p) or np.isfinite(p["sd"]) for p in doc["parameters"].values())
    assert "held out by cycles" in r.stdout and "model: " in r.stdout
    assert doc["force_reads_low"] is None and "reads at least" not in r.stdout
    # the model is a reference for QA and the report's overlay, along the run's own motion
    r = dyno("check", tmp_path / "x.mcap", "--against", tmp_path / "x.minimal.json")
    assert r.returncode == 0 and "PASS: 8 of 8" in r.stdout, r.stdout + r.stderr
    r = dyno("report", tmp_path / "x.mcap", "--model", tmp_path / "x.minimal.json", "--out", tmp_path / "overlaid")
    page = (tmp_path / "overlaid" / "index.html").read_text()
    assert r.returncode == 0 and "Model overlaid: x.minimal.json" in page and "compression peak" not in page
    one_line_error(dyno("check", tmp_path / "x.mcap", "--against", src.with_suffix(".json")), "no such file")
    # with a description for layout and geometry: its gas charge is another damper's, refitted
    r = dyno("identify", tmp_path / "x.mcap", "--damper", "koni", "--out", tmp_path / "koni-like.json")
    assert r.returncode == 0 and "gas charge refitted from the force at the velocity reversals" in r.stdout, \
        r.stdout + r.stderr
    assert float(r.stdout.split("held-out loop NRMSE: ")[1].split(" %")[0]) < 5.0
    one_line_error(dyno("identify", tmp_path / "x.mcap", "--report", tmp_path / "rep"), "need a damper description")


def test_a_force_smoothed_by_its_source_is_said_as_such_and_white_noise_is_not():
    from records import source_filter
    from models.diagnose import quality
    rng = np.random.default_rng(1)
    t = np.arange(20_000) / 1000.0  # 20 s at 1 kHz of a 1.3 Hz sine, as the UTFSM files
    F = 800 * np.tanh(6 * np.cos(2 * np.pi * 1.3 * t)) + rng.normal(0, 5, len(t))
    cycles = [(1.3, 0.0, t[-1])]
    assert quality.smoothed("force", t, F, cycles) == []
    averaged = np.convolve(F, np.ones(77) / 77, "same")  # a tenth of a period
    flag = quality.smoothed("force", t[100:-100], averaged[100:-100], cycles)
    assert len(flag) == 1 and "smoothed by its source" in flag[0].message
    # how wide, read from the noise's correlation (a triangle 77 samples wide), to import it with:
    # short, as the flag says (each cycle's trend removed takes the long lags)
    width = int(flag[0].message.split("a moving average of about ")[1].split(" samples")[0])
    assert 0.6 * 77 <= width <= 1.1 * 77 and f"--smoothed, e.g. {round(width * 1.3e-3, 2):g}period or {width}ms" \
        in flag[0].message and "runs up to a third short" in flag[0].message, flag[0].message
    declared = quality.smoothed("force", t[100:-100], averaged[100:-100], cycles, source_filter.parse("77ms"))
    assert "through the moving average of 0.077 s its import declared" in declared[0].message
    # a second stretch, not smoothed: the source would have smoothed both
    assert quality.smoothed("force", t, np.where(t < 10, np.convolve(F, np.ones(77) / 77, "same"), F),
                            [(1.3, 0.5, 9.5), (1.3, 10.5, 19.5)]) == []


def test_the_diagnosis_holds_out_the_tail_of_a_recording_of_several_strokes(tmp_path):
    """--holdout tail:F judges only the last segments; the noise is read where it judges."""
    parts = [crank(n=int(12 / hz * RATE), hz=hz) for hz in (0.8, 1.6)]
    t = np.concatenate([parts[0][0], parts[1][0] + parts[0][0][-1] + 1 / RATE])
    x, F = (np.concatenate([p[i] for p in parts]) for i in (1, 2))
    F = F + np.random.default_rng(2).normal(0, 3.0, len(F))
    src = _written(tmp_path, "two.csv", "t,x,F\n" + "".join(f"{a:.5f},{1e3 * b:.4f},{c:.3f}\n"
                                                            for a, b, c in zip(t, x, F)))
    _imported(tmp_path, src, "--map", "time=t", "--map", "displacement=x:mm", "--map", "force=F")
    r = dyno("diagnose", tmp_path / "x.mcap", "--holdout", "tail:0.15")
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr
    assert "the last 15 % held out" in r.stdout and "what differs from one cycle to the next at the same point of the stroke" in r.stdout


def test_repeats_that_differ_are_named_and_each_is_identified_alone(tmp_path):
    """One test run twice with a setting changed between (a clicker, a coil current) that
    the file does not carry: one model cannot follow both, identify says so and fits each
    with --segment."""
    t, x, F = crank(n=int(10 / 1.05 * RATE))
    hold = np.arange(1, int(RATE)) / RATE
    F2 = F + 3000 * np.gradient(x, t)  # the same stroke, stiffer valves
    t = np.concatenate([t, t[-1] + hold, t + t[-1] + 1.0])
    x = np.concatenate([x, np.full(len(hold), x[-1]), x])
    F = np.concatenate([F, np.full(len(hold), F[-1]), F2]) + np.random.default_rng(3).normal(0, 3.0, len(t))
    n1 = len(F2)  # the first run's samples
    src = _written(tmp_path, "two.csv", "t,x,F\n" + "".join(f"{a:.5f},{1e3 * b:.4f},{c:.3f}\n"
                                                            for a, b, c in zip(t, x, F)))
    _, _, r = _imported(tmp_path, src, "--map", "time=t", "--map", "displacement=x:mm", "--map", "force=F")
    assert "sine 19 mm 1.05 Hz (2)" in r.stdout, r.stdout
    r = dyno("identify", tmp_path / "x.mcap")
    assert r.returncode == 0 and "note: sine 19 mm 1.05 Hz was run 2 times" in r.stdout, r.stdout + r.stderr
    r = dyno("diagnose", tmp_path / "x.mcap", "--json")  # the diagnosis says it too (the UTFSM ME file's currents)
    doc = json.loads(r.stdout)
    assert doc["repeats_differ"][0]["segments"] == ["sine 19 mm 1.05 Hz", "sine 19 mm 1.05 Hz (2)"]
    assert "Repeats that differ: sine 19 mm 1.05 Hz was run 2 times" in doc["summary"]
    r = dyno("identify", tmp_path / "x.mcap", "--segment", "sine 19 mm 1.05 Hz (2)", "--json", "--out",
             tmp_path / "second.json")
    doc = json.loads(r.stdout)
    assert r.returncode == 0 and doc["segments"] == ["sine 19 mm 1.05 Hz (2)"] and doc["heldout_nrmse"] < 0.02
    assert doc["repeats_differ"] == []
    one_line_error(dyno("identify", tmp_path / "x.mcap", "--segment", "sine 5 mm", "--out", tmp_path / "o.json"),
                   "no segment 'sine 5 mm'", "sine 19 mm 1.05 Hz (2)")
    # the velocity table is the first run's, not the mean of two settings, and the sheet says so:
    # the same as the table of a file that holds the first run alone
    assert dyno("report", tmp_path / "x.mcap", "--out", tmp_path / "both").returncode == 0
    first = _written(tmp_path, "first.csv", "t,x,F\n" + "".join(f"{a:.5f},{1e3 * b:.4f},{c:.3f}\n" for a, b, c
                                                                in zip(t[:n1], x[:n1], F[:n1])))
    assert dyno("import", first, "--out", tmp_path / "first.mcap", "--map", "time=t", "--map", "displacement=x:mm",
                "--map", "force=F").returncode == 0
    assert dyno("report", tmp_path / "first.mcap", "--out", tmp_path / "first").returncode == 0
    table = [(tmp_path / d / "velocity.csv").read_text().splitlines() for d in ("both", "first")]
    assert len(table[0]) > 2 and table[0] == table[1], table
    assert ("The table is sine 19 mm 1.05 Hz's alone: 1 later run of the test differs from it by more than 15 %"
            in html.unescape((tmp_path / "both" / "index.html").read_text()))
    r = dyno("check", tmp_path / "x.mcap", "--against", tmp_path / "first.mcap")  # the first run against itself
    assert r.returncode == 0 and "run: The table is sine 19 mm 1.05 Hz's alone" in r.stdout, r.stdout + r.stderr
    assert dyno("report", tmp_path / "x.mcap", tmp_path / "first.mcap", "--out", tmp_path / "cmp").returncode == 0
    assert "A: The table is sine 19 mm 1.05 Hz's alone" in html.unescape((tmp_path / "cmp" / "index.html").read_text())


def test_repeats_whose_estimated_frequency_differs_in_the_last_digit_are_one_test(tmp_path):
    """Five repeats of one test at five settings, each cycle counted from the file: their
    estimated frequencies differ in the third digit, and they are one test run five times."""
    parts, t0 = [], 0.0
    for k, hz in enumerate((1.050, 1.056, 1.044, 1.061, 1.053)):
        t, x, F = crank(n=int(10 / hz * RATE), hz=hz)
        F = F + 1500 * k * np.gradient(x, t)  # stiffer each time (a coil current, a clicker)
        hold = np.arange(1, int(RATE)) / RATE
        parts.append((np.concatenate([t, t[-1] + hold]) + t0, np.concatenate([x, np.full(len(hold), x[-1])]),
                      np.concatenate([F, np.full(len(hold), F[-1])])))
        t0 = parts[-1][0][-1] + 1 / RATE
    t, x, F = (np.concatenate([p[i] for p in parts]) for i in range(3))
    F = F + np.random.default_rng(4).normal(0, 3.0, len(t))
    src = _written(tmp_path, "five.csv", "t,x,F\n" + "".join(f"{a:.5f},{1e3 * b:.4f},{c:.3f}\n"
                                                              for a, b, c in zip(t, x, F)))
    _, _, r = _imported(tmp_path, src, "--map", "time=t", "--map", "displacement=x:mm", "--map", "force=F")
    assert "in 5 sines" in r.stdout, r.stdout
    first = r.stdout.split("segments: ")[1].split("; ")[1].split(" (")[0]
    assert all(f"{first} ({k}) (" in r.stdout for k in range(2, 6)), r.stdout
    r = dyno("identify", tmp_path / "x.mcap", "--out", tmp_path / "m.json")
    assert f"note: {first} was run 5 times" in r.stdout, r.stdout + r.stderr


def test_five_runs_of_one_test_at_five_currents_are_all_compared(tmp_path):
    """The UTFSM damper's 25 mm 0.5 Hz test at five coil currents (real files, their
    frequencies estimated 0.507 and 0.508 Hz): the comparison tables all five."""
    src = Path(__file__).parent / "data" / "mr-damper-utfsm" / "sine"
    recs = []
    for current in ("0", "0x25", "0x5", "0x75", "1"):
        recs.append(tmp_path / f"{current}.mcap")
        r = dyno("import", src / f"25mm0x5Hz{current}A.txt", "--out", recs[-1], "--map", "time=1:s", "--map",
                 "displacement=2:mm", "--map", "velocity=3:mm/s", "--map", "force=4:N", "--smoothed", "0.1period",
                 "--serial", "MR-1", "--setup", f"current_A={current.replace('x', '.')}", "--note", "UTFSM")
        assert r.returncode == 0, r.stderr
    # each run of one speed is trended as its report's velocity table reads it (along the stroke)
    r = dyno("runs", "trend", tmp_path, "--serial", "MR-1", "--quantity", "compression@25mm/s")
    trended = {line.split("|")[4].strip(): float(line.split("|")[2]) for line in r.stdout.splitlines()[2:]}
    assert r.returncode == 0 and len(trended) == 5, r.stdout + r.stderr
    r = dyno("report", recs[-1], "--out", tmp_path / "one")
    page = (tmp_path / "one" / "index.html").read_text()
    assert "damper serial: MR-1" in page and "current_A 1" in page and "note: UTFSM" in page
    row = next(line for line in (tmp_path / "one" / "velocity.csv").read_text().splitlines() if line.startswith("25,"))
    assert trended["current_A=1"] == pytest.approx(float(row.split(",")[1]), rel=1e-3)
    r = dyno("report", *recs, "--out", tmp_path / "cmp")
    assert r.returncode == 0, r.stderr
    rows = (tmp_path / "cmp" / "differences.csv").read_text().splitlines()[1:]
    assert [row.split(",")[0] for row in rows] == ["B", "C", "D", "E"]
    forces = [float(row.split(",")[5]) for row in rows]
    assert forces == sorted(forces) and forces[0] > float(rows[0].split(",")[4])  # more current, more force
    assert (tmp_path / "cmp" / "compare_loops.png").is_file()
    assert "is not in the table" not in (tmp_path / "cmp" / "index.html").read_text()
    # a run of another test is left out of the table, and the page says so with why
    t, x, F = crank(n=int(12 / 1.05 * RATE))
    crank_csv = _written(tmp_path, "crank.csv", "t,x,F\n" + "".join(f"{a:.5f},{1e3 * b:.4f},{c:.3f}\n"
                                                                    for a, b, c in zip(t, x, F)))
    _imported(tmp_path, crank_csv, "--map", "time=t", "--map", "displacement=x:mm", "--map", "force=F")
    r = dyno("report", recs[0], recs[4], tmp_path / "x.mcap", "--out", tmp_path / "three")
    page = (tmp_path / "three" / "index.html").read_text()
    assert r.returncode == 0 and "C is not in the table of peak forces: none of its tests (19 mm 1.05 Hz)" in page
    assert "B is not in the table" not in page


def test_a_report_holds_no_value_the_file_does_not(tmp_path):
    """An MR file without a thermocouple shows no temperature (not a room's 20 C), and the
    options import was not given are no empty fields on the page."""
    src = Path(__file__).parent / "data" / "mr-damper-utfsm" / "sine" / "25mm0x5Hz1A.txt"
    _imported(tmp_path, src, "--map", "time=1:s", "--map", "displacement=2:mm", "--map", "velocity=3:mm/s", "--map",
              "force=4:N", "--smoothed", "0.1period")
    r = dyno("report", tmp_path / "x.mcap", "--out", tmp_path / "rep")
    assert r.returncode == 0, r.stderr
    head, row = (line.split(",") for line in (tmp_path / "rep" / "peaks.csv").read_text().splitlines()[:2])
    assert row[head.index("T_C")] == ""
    page = (tmp_path / "rep" / "index.html").read_text()
    assert "no body temperature" in page and "20.00" not in page
    assert "flip ;" not in page and "damper ?" not in page


@pytest.mark.parametrize("rod, ratio", [(0.1, 0.30), (0.12, 0.16)])
def test_a_slider_cranks_speed_over_2_pi_f_a_is_its_geometry_not_an_actuator(tmp_path, rod, ratio):
    """A slider crank's peak speed lies above 2 pi f A by its rod ratio (4.4 % at r/l 0.3)."""
    t, x, F = crank(n=int(12 / 1.05 * RATE), stroke=0.06 if rod == 0.1 else 0.038, rod=rod)
    src = _written(tmp_path, "crank.csv", "t,x,F\n" + "".join(f"{a:.5f},{1e3 * b:.4f},{c:.3f}\n"
                                                              for a, b, c in zip(t, x, F)))
    _imported(tmp_path, src, "--map", "time=t", "--map", "displacement=x:mm", "--map", "force=F")
    r = dyno("report", tmp_path / "x.mcap", "--out", tmp_path / "rep")
    page = (tmp_path / "rep" / "index.html").read_text()
    assert r.returncode == 0 and f"crank-to-rod ratio r/l about {ratio:.2f}" in page
    assert "actuator" not in page


def test_rows_with_no_number_are_counted_at_import_and_a_stopped_diagnosis_says_so(tmp_path):
    """NaN or empty force cells, imported with --allow-gaps (refused without it: test_hostile_inputs),
    are left out of the force and said with their count and lines; an operator's stop of a
    diagnosis ends in one line, exit 130."""
    import subprocess
    import sys

    from tests.conftest import operator_stopped
    t, x, F = crank(n=int(12 / 1.05 * RATE))
    cells = ["NaN" if i % 50 == 7 else "" if i % 97 == 3 else f"{f:.3f}" for i, f in enumerate(F)]
    src = _written(tmp_path, "nan.csv", "t,x,F\n" + "".join(f"{a:.5f},{1e3 * b:.4f},{c}\n"
                                                            for a, b, c in zip(t, x, cells)))
    channels, _, r = _imported(tmp_path, src, "--map", "time=t", "--map", "displacement=x:mm", "--map", "force=F",
                               "--allow-gaps")
    empty = sum(c in ("NaN", "") for c in cells)
    assert f"force: {empty} of {len(t)} rows hold no number" in r.stdout and len(channels["force"][0]) == len(t) - empty
    lines = [i + 2 for i, c in enumerate(cells) if c in ("NaN", "")]  # the header is line 1
    assert f"(lines {', '.join(map(str, lines[:8]))} and {empty - 8} more)" in r.stdout, r.stdout
    p = subprocess.Popen([str(Path(sys.executable).parent / "dyno"), "diagnose", str(tmp_path / "x.mcap")],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    said = p.stderr.readline()  # the diagnosis's first progress line: it is under way
    assert said, "the diagnosis ended before it said anything"
    assert "stopped by the operator" in operator_stopped(p)


def test_a_negative_fitted_mass_is_not_printed_as_measured(tmp_path):
    """A source that took a fixture's mass off twice leaves -30 kg times the acceleration in
    the force: the diagnosis keeps an inertia term, whose mass below zero is said as no
    measurement (and not catalogued as one). Two crank speeds: at one, m a = -m w^2 x is a
    spring as much as a mass (read whole, the 4 Hz run alone was named an elastic stroke)."""
    parts, t0 = [], 0.0
    for hz in (4.0, 2.0):
        t, x, F = crank(n=int(6 * RATE), hz=hz)
        w, r = 2 * np.pi * hz, 0.019  # the crank's acceleration as it is (twice differenced, its ends would be off)
        a = w * w * (r * np.cos(w * t) + (r * r / 0.12) * np.cos(2 * w * t))
        parts.append((t + t0, x, F - 30.0 * a))
        t0 += t[-1] + 1 / RATE
    t, x, F = (np.concatenate([p[i] for p in parts]) for i in range(3))
    F = F + np.random.default_rng(1).normal(0, 3.0, len(t))
    src = _written(tmp_path, "m.csv", "t,x,F\n" + "".join(f"{a:.5f},{1e3 * b:.4f},{c:.3f}\n"
                                                          for a, b, c in zip(t, x, F)))
    _imported(tmp_path, src, "--map", "time=t", "--map", "displacement=x:mm", "--map", "force=F")
    r = dyno("identify", tmp_path / "x.mcap", "--out", tmp_path / "m.json")
    assert r.returncode == 0, r.stderr
    line = next(ln for ln in r.stdout.splitlines() if ln.strip().startswith("m_oil"))
    # below the floor physics sets, or held at the range's end below it: either way no measurement
    assert float(line.split()[1]) < 0 and "undetermined" in line and "not measured" in line, line
    assert "fluid_inertia (its m_oil not measured)" in r.stdout
    from views import run_index
    with run_index.reading(tmp_path) as c:
        (model,) = run_index.attached(c, "models", run_index.runs(c)[0]["id"])
    assert "m_oil" not in json.loads(model["parameters"]) and "c1_c" in json.loads(model["parameters"])


def test_a_model_that_does_not_predict_is_refused_or_kept_marked_poor(tmp_path):
    """A force whose noise is as large as the damper's own: the held-out error exceeds the
    limit, so no model is written (exit 1, saying why); --keep-poor writes it marked poor,
    and the run index shows it so."""
    t, x, F = crank(n=int(12 / 1.05 * RATE))
    F = F + np.random.default_rng(1).normal(0, 400.0, len(t))
    src = _written(tmp_path, "n.csv", "t,x,F\n" + "".join(f"{a:.5f},{1e3 * b:.4f},{c:.3f}\n"
                                                          for a, b, c in zip(t, x, F)))
    _imported(tmp_path, src, "--map", "time=t", "--map", "displacement=x:mm", "--map", "force=F")
    r = dyno("identify", tmp_path / "x.mcap")
    err = r.stderr.strip().splitlines()[-1]
    assert r.returncode == 1 and "a model must stay within 10 %" in err and "noise alone" in err, r.stderr
    assert not (tmp_path / "x.minimal.json").exists()
    r = dyno("identify", tmp_path / "x.mcap", "--keep-poor", "--json")
    assert r.returncode == 0 and json.loads(r.stdout)["poor"].startswith("the minimal law misses"), r.stderr
    assert json.loads((tmp_path / "x.minimal.json").read_text())["poor"]
    r = dyno("runs", "show", "1", tmp_path)
    assert "(poor: beyond 10 %)" in r.stdout, r.stdout + r.stderr
    # --batch, each file as a single identification: refused in its row (exit 1), or kept marked poor
    r = dyno("identify", "--batch", tmp_path / "x.mcap", "--damper", "koni", "--summary", tmp_path / "s.csv")
    row = (tmp_path / "s.csv").read_text().splitlines()[1]
    assert r.returncode == 1 and "no model written (--keep-poor" in row and not (tmp_path / "x.model.json").exists()
    r = dyno("identify", "--batch", tmp_path / "x.mcap", "--damper", "koni", "--summary", tmp_path / "s.csv",
             "--keep-poor", "--overwrite")
    assert r.returncode == 0 and json.loads((tmp_path / "x.model.json").read_text())["name"].endswith("-poor")


def test_every_effect_of_the_catalogue_is_said_in_a_sentence():
    """Each effect the diagnosis may accept has its sentence (cavitation's ended in a
    KeyError on a real MR recording)."""
    from models.diagnose.candidates import EFFECTS
    from models.diagnose.result import Step
    from models.diagnose.words import sentence

    class Values(dict):  # every parameter a plausible number, every interval about it
        def __missing__(self, key):
            return 1e-3

    class Intervals(dict):
        def __missing__(self, key):
            return (1e-3, 2e-3)
    for key in EFFECTS:
        effect = f"{key}:aux.x" if key in ("aux_channel", "bouc_wen") else key
        step = Step(effect, 0.05, 0.03, Values(), Intervals(), 1e-4, np.zeros(3), np.zeros(3), [], [], [],
                    region="speed 0-1 m/s", size_rms_n=10.0, size_peak_n=20.0)
        text = sentence(step)
        assert "Held-out error falls from 5 % to 3 %" in text and "{" not in text, (key, text)


def test_an_imported_run_compares_and_checks_against_a_run_of_ours(tmp_path, koni_run):
    t, x, F = crank(n=int(12 / 1.05 * RATE))
    src = _written(tmp_path, "crank.csv", "t,x,F\n" + "".join(f"{a:.5f},{1e3 * b:.4f},{c:.3f}\n"
                                                              for a, b, c in zip(t, x, F)))
    _imported(tmp_path, src, "--map", "time=t", "--map", "displacement=x:mm", "--map", "force=F")
    r = dyno("report", koni_run[0], tmp_path / "x.mcap", "--out", tmp_path / "cmp")
    assert r.returncode == 0, r.stderr
    page = (tmp_path / "cmp" / "index.html").read_text()
    assert "compared by their velocity tables and curves" in page and "Every run read the same way (along the stroke" \
        in page and (tmp_path / "cmp" / "compare_composite.png").stat().st_size > 10_000
    from pypdf import PdfReader  # a comparison is printed too: its sheet, then why it reads that way
    pages = [" ".join(p.extract_text().split()) for p in PdfReader(tmp_path / "cmp" / "report.pdf").pages]
    assert "Damper comparison sheet" in pages[0] and "B diff comp/" in pages[0]
    assert "compared by their velocity tables" in pages[1]
    r = dyno("check", tmp_path / "x.mcap", "--against", koni_run[0])  # another damper: measured, and failed
    assert r.returncode == 1 and "FAIL: 0 of" in r.stdout and " 100 mm/s compression " in r.stdout, r.stdout + r.stderr


def test_a_recording_of_three_cycles_is_judged_by_quarter_cycles(tmp_path):
    """A slow sine of three whole cycles (the UTFSM 0.1 Hz files) is too short to hold out
    whole cycles: its quarter cycles are fitted and judged alternately, and the answer says so."""
    t, x, F = crank(n=int(3.6 / 0.1 * 50), rate=50.0, hz=0.1)
    F = F + np.random.default_rng(3).normal(0, 2.0, len(F))
    src = _written(tmp_path, "slow.csv", "t,x,F\n" + "".join(f"{a:.4f},{1e3 * b:.4f},{c:.3f}\n"
                                                             for a, b, c in zip(t, x, F)))
    _, _, r = _imported(tmp_path, src, "--map", "time=t", "--map", "displacement=x:mm", "--map", "force=F")
    assert "(3 cycles)" in r.stdout, r.stdout
    r = dyno("identify", tmp_path / "x.mcap")
    assert r.returncode == 0, r.stderr
    assert float(r.stdout.split("held out by cycles: ")[1].split(" %")[0]) < 5.0, r.stdout
    r = dyno("diagnose", tmp_path / "x.mcap", "--holdout", "tail:0.15")
    assert r.returncode == 0 and "(only 3 whole cycles): fitted and held out by quarter cycles" in r.stdout, \
        r.stdout + r.stderr


def _random_run(tmp_path, name, seed, gain=1.0):
    """An imported random-input run (band-limited 0.3-4 Hz, 8 mm RMS, 200 Hz, a velocity
    column as such files carry) of the crank test's damper, its damping scaled by gain;
    (recording, mean displacement [m])."""
    rng = np.random.default_rng(seed)
    h, n = 1 / 200.0, 12_000
    spec = np.fft.rfft(rng.normal(size=n))
    f = np.fft.rfftfreq(n, h)
    spec[(f < 0.3) | (f > 4.0)] = 0
    x = 0.05 + 0.008 * (lambda y: y / np.std(y))(np.fft.irfft(spec, n))
    t = np.arange(n) * h
    v = np.gradient(x, h)
    F = 150 + 800 * x + gain * np.where(v > 0, 2500 * v, 4200 * v) + 30 * np.tanh(v / 0.01) + rng.normal(0, 3, n)
    src = _written(tmp_path, f"{name}.csv", "t,x,v,F\n" + "".join(f"{a:.4f},{1e3 * b:.4f},{1e3 * c:.3f},{d:.3f}\n"
                                                                   for a, b, c, d in zip(t, x, v, F)))
    out = tmp_path / f"{name}.mcap"
    r = dyno("import", src, "--out", out, "--map", "time=t", "--map", "displacement=x:mm", "--map", "velocity=v:mm/s",
             "--map", "force=F")
    assert r.returncode == 0 and "segments: 100 % in 1 stretch of random motion\n" in r.stdout, r.stdout + r.stderr
    return out, float(np.mean(x))


def test_a_random_input_is_read_by_speed_for_the_velocity_table_and_the_check(tmp_path):
    """A random-input file has no stroke that repeats: its velocity table is the mean force at
    each speed over all samples, and `check` compares two such runs at those speeds."""
    a, xm = _random_run(tmp_path, "a", 1)
    r = dyno("report", a, "--out", tmp_path / "rep")
    assert r.returncode == 0, r.stderr
    page = (tmp_path / "rep" / "index.html").read_text()
    assert "the force-velocity scatter" in page and "Force against shaft speed" in page
    rows = {float(r[0]): r[1:3] for r in (ln.split(",") for ln in
                                          (tmp_path / "rep" / "velocity.csv").read_text().splitlines()[1:])}
    for speed in (50.0, 100.0):  # the damper's curve at that speed, within 1 % of the force range (11 N)
        v = speed / 1e3
        comp, reb = (150 + 800 * xm + 2500 * v + 30), (150 + 800 * xm - 4200 * v - 30)
        assert abs(float(rows[speed][0]) - comp) < 11 and abs(float(rows[speed][1]) - reb) < 11, (rows, comp, reb)
    b, _ = _random_run(tmp_path, "b", 2)
    r = dyno("check", b, "--against", a, "--tolerance", "5%")
    assert r.returncode == 0 and "PASS" in r.stdout, r.stdout + r.stderr
    c, _ = _random_run(tmp_path, "c", 3, gain=1.3)
    r = dyno("check", c, "--against", a, "--tolerance", "5%")
    assert r.returncode == 1 and "FAIL" in r.stdout, r.stdout + r.stderr


@pytest.mark.rounding
def test_identify_keeps_the_effects_the_diagnosis_accepts_and_check_reads_them(tmp_path):
    """A crank file whose force channel lags 4 ms: the model that needs no description takes
    the sensor delay the diagnosis accepts, says both held-out errors, and `check` and
    `report` evaluate it along the recording it was built on; without that recording, one line."""
    import shutil
    t, x, F = crank(n=int(20 / 1.05 * RATE))
    F = np.interp(t - 0.004, t, F) + np.random.default_rng(0).normal(0, 5.0, len(F))
    src = _written(tmp_path, "lag.csv", "t,x,F\n" + "".join(f"{a:.5f},{1e3 * b:.4f},{c:.3f}\n"
                                                            for a, b, c in zip(t, x, F)))
    _imported(tmp_path, src, "--map", "time=t", "--map", "displacement=x:mm", "--map", "force=F")
    r = dyno("identify", tmp_path / "x.mcap")
    assert r.returncode == 0 and "with the effects the diagnosis accepts (" in r.stdout, r.stdout + r.stderr
    assert "identified on 1.05 Hz, amplitudes 19 mm, speeds to " in r.stdout, r.stdout
    doc = json.loads((tmp_path / "x.minimal.json").read_text())
    # at one frequency a lag and oil in series with the valves are nearly one loop (their held-out
    # gains 0.30 and 0.29 noise variances): the model keeps one of them, the recording cannot say which
    assert [e for e in doc["effects"] if e != "alignment"] in (["sensor_delay"], ["compressibility"])
    assert doc["source"] == ["x.mcap"]
    assert doc["heldout_nrmse"] < doc["baseline_heldout_nrmse"]
    if "tau" in doc["parameters"]:
        assert abs(abs(doc["parameters"]["tau"]["value"]) - 0.004) < 0.001  # (its sign: the diagnosis's convention)
    r = dyno("check", tmp_path / "x.mcap", "--against", tmp_path / "x.minimal.json", "--tolerance", "2%")
    assert r.returncode == 0 and "PASS" in r.stdout and "outside what" not in r.stdout, r.stdout + r.stderr
    # where it was measured, and a run beyond it: its force there is the model's extrapolation
    on = doc["identified_on"]
    assert on["freq_hz"] == pytest.approx([1.05, 1.05], rel=0.01) and on["amplitude_m"][0] == pytest.approx(0.019, rel=0.02)
    t2, x2, F2 = crank(n=int(6 / 2.1 * RATE), hz=2.1)
    fast = _written(tmp_path, "fast.csv", "t,x,F\n" + "".join(f"{a:.5f},{1e3 * b:.4f},{c:.3f}\n"
                                                              for a, b, c in zip(t2, x2, F2)))
    assert dyno("import", fast, "--out", tmp_path / "fast.mcap", "--map", "time=t", "--map", "displacement=x:mm",
                "--map", "force=F").returncode == 0
    r = dyno("check", tmp_path / "fast.mcap", "--against", tmp_path / "x.minimal.json")
    assert "outside what the model was identified on, its force is extrapolated there: this run's 2.1 Hz (it was " \
           "identified on 1.05 Hz); speeds to " in r.stdout, r.stdout + r.stderr
    r = dyno("report", tmp_path / "x.mcap", "--model", tmp_path / "x.minimal.json", "--out", tmp_path / "rep")
    assert r.returncode == 0, r.stderr
    (tmp_path / "moved").mkdir()
    shutil.copy(tmp_path / "x.minimal.json", tmp_path / "moved")
    one_line_error(dyno("check", tmp_path / "x.mcap", "--against", tmp_path / "moved" / "x.minimal.json"),
                   "its effects are built on the recording it was fitted on")


@pytest.mark.parametrize("n", [11, 12, 57, 5000])
def test_the_derived_velocity_is_scipys_savitzky_golay_derivative(n):
    """Import derives velocity with its own Savitzky-Golay slope (scipy.signal's import costs
    a second): the same numbers as scipy's, edges included."""
    from scipy.signal import savgol_filter
    from records.velocity import savgol_slope
    x = np.cumsum(np.random.default_rng(n).normal(size=n))
    assert np.allclose(savgol_slope(x, 0.003), savgol_filter(x, 11, 2, deriv=1, delta=0.003), rtol=0, atol=1e-9)


def test_an_aux_reading_scales_no_effect_unless_the_recording_says_it_drives_the_damper(tmp_path):
    """Issue 44: an aux.* channel (here the actuator's command, as in the UTFSM chirps) scales
    an effect only when the recording declares it drives the damper (--drive NAME=KIND)."""
    t, x, F = crank(n=int(12 / 1.05 * RATE))
    cmd = x + np.random.default_rng(4).normal(0, 1e-4, len(x))
    src = _written(tmp_path, "aux.csv", "t,x,F,cmd\n" + "".join(f"{a:.5f},{1e3 * b:.4f},{c:.3f},{1e3 * d:.4f}\n"
                                                                  for a, b, c, d in zip(t, x, F, cmd)))
    maps = ("--map", "time=t", "--map", "displacement=x:mm", "--map", "force=F", "--map", "aux.command=cmd:mm")
    _imported(tmp_path, src, *maps)
    r = dyno("diagnose", tmp_path / "x.mcap")
    assert r.returncode == 0 and "aux.command: the recording does not say it drives the damper" in r.stdout, r.stdout
    assert ":aux.command" not in r.stdout.split("Candidates")[1]  # no candidate scaled by it
    one_line_error(dyno("import", src, "--out", tmp_path / "y.mcap", *maps, "--drive", "aux.command=magic"),
                   "say what it drives: aux.command=coil current")
    _, meta, _ = _imported(tmp_path, src, *maps, "--drive", "aux.command=valve command", "--overwrite")
    assert json.loads(meta["calibration"]["aux.command"])["drives"] == "valve command"
    r = dyno("diagnose", tmp_path / "x.mcap")
    assert r.returncode == 0 and "does not say it drives" not in r.stdout and ":aux.command" in r.stdout, r.stdout


def test_a_path_that_does_not_close_is_not_read_as_the_other_sign():
    """A static test's move against the gas force stores energy, it does not dissipate it:
    the sign check leaves the force's part that depends on position alone out (the live
    identification met it on the standard run's first segments and advised --flip)."""
    from records.data import other_sign
    t = np.linspace(0, 20, 20_000)
    x = 0.03 - 0.001 * t  # extending 20 mm against a 600-760 N gas force: -15 J
    v = np.gradient(x, t)
    F = 600 + 8000 * x + 30 * np.tanh(v / 1e-3) + 3000 * v
    assert other_sign(x, F) is None
    t = np.linspace(0, 10, 10_000)
    x = 0.03 + 0.01 * np.sin(2 * np.pi * t)
    v = np.gradient(x, t)
    F = 600 + 8000 * x + 30 * np.tanh(v / 1e-3) + 3000 * v
    assert other_sign(x, F) is None
    assert "import it again with --flip displacement" in other_sign(0.08 - x, F)
    assert "import it again with --flip force" in other_sign(x, -F)


def test_a_sweep_beside_a_sine_is_read_as_a_sweep_by_import_report_and_diagnosis(tmp_path):
    """The UTFSM chirp's case: a sweep from 0.5 to 2.5 Hz changes its period too fast to be
    cut into sines, and before issue 88 9.6 s of its strokes were read by nothing. Now the
    import names it a sweep with its frequencies, the diagnosis judges it in blocks beside
    the sine's cycles, and the report draws it apart. A hole in the file (the ME file's
    acquisition paused between currents) is in no segment, however far x moved across it."""
    from records.segmentation import division, find
    rate = 200.0
    t = np.arange(int(8 * rate)) / rate
    sweep = 0.004 * np.sin(2 * np.pi * (0.5 * t + 0.125 * t ** 2))  # 0.5 to 2.5 Hz in 8 s
    ts = 8 + np.arange(int(4 * rate)) / rate
    t, x = np.r_[t, ts], 0.04 + np.r_[sweep, 0.004 * np.sin(2 * np.pi * 3.0 * (ts - 8))]
    F = 2500 * np.gradient(x, t) + np.random.default_rng(4).normal(0, 3.0, len(t))
    src = _written(tmp_path, "sweep.csv", "t,x,F\n" + "".join(f"{a:.4f},{1e3 * b:.4f},{c:.3f}\n"
                                                              for a, b, c in zip(t, x, F)))
    _, _, r = _imported(tmp_path, src, "--map", "time=t", "--map", "displacement=x:mm", "--map", "force=F")
    said = r.stdout.split("segments: ")[1].split("\n")[0]
    assert "in 1 sweep" in said and "in 1 sine" in said and "sine 4 mm 3 Hz (12 cycles)" in said, said
    found = find(t, x)
    sweep_seg = next(s for s in found if s.kind == "sweep")
    assert sweep_seg.t0 < 1.0 and 7.5 < sweep_seg.t1 <= 8.01, found
    assert 0.5 <= sweep_seg.params["f_start_hz"] < 1.0 and 2.2 < sweep_seg.params["f_end_hz"] <= 2.5, sweep_seg
    r = dyno("diagnose", tmp_path / "x.mcap")
    unread = [line for line in r.stdout.splitlines() if line.startswith("Not assessed:")]
    assert r.returncode == 0 and unread == ["Not assessed: no temperature channel: gas and damping temperature "
                                            "effects not assessed."], r.stdout + r.stderr
    from models.diagnose.data import prepare
    from records.reader import load_recording
    ch, events, _ = load_recording(tmp_path / "x.mcap")
    d = prepare(ch, events)
    read = {name: np.ptp(d.t[d.segment == i]) for i, (name, _) in enumerate(d.segments)}
    assert read[sweep_seg.name] > 6.0 and [f for n, f in d.segments if n == sweep_seg.name] == [None], read
    assert dyno("report", tmp_path / "x.mcap", "--out", tmp_path / "rep").returncode == 0
    page = html.unescape((tmp_path / "rep" / "index.html").read_text())
    assert f"cut into its tests at import (docs/recording.md): {said.split('; ')[0]}" in page, page
    assert (tmp_path / "rep" / "blocks.png").stat().st_size > 10_000  # its loops, drawn apart
    tt = np.arange(400) / rate  # a 3 Hz sine, a 20 s hole, the sine again: the hole alone in no segment
    t2, x2 = np.r_[tt, tt + 22.0], np.r_[0.04 + 0.004 * np.sin(6 * np.pi * tt)] * np.ones(2)[:, None]
    x2 = x2.ravel()
    cut = find(t2, x2)
    assert sum(s.t1 - s.t0 for s in cut) == pytest.approx(2 * tt[-1], abs=0.01), cut
    assert division(cut, t2[-1] - t2[0]).endswith("% in no segment (holes in the time stamps)")


def test_a_headerless_file_is_mapped_from_its_values(tmp_path):
    """The UTFSM sine files: four columns, no header, no names to guess from. Time rises by
    one step a row, the third column is the rate of change of the second (velocity, so the
    second is displacement; in mm, as no damper strokes a metre), the force is the one
    left. A sample counter's step of 1 is no time."""
    t, x, F = crank()
    v = np.r_[np.diff(x) / np.diff(t), 0.0]  # the source's own difference, forward
    src = _written(tmp_path, "sine.txt", "".join(f"   {a:.7e}  {1e3 * b:.7e}  {1e3 * c:.7e}  {d:.7e}\n"
                                                 for a, b, c, d in zip(t, x, v, F)))
    r = dyno("import", src, "--inspect")
    said = r.stdout.split("guessed from the values (check the units): ")[1]
    maps = said.split(" (")[0].replace("'", "").split()
    assert maps == ["--map", "time=1", "--map", "displacement=2:mm", "--map", "velocity=3:mm/s", "--map", "force=4"], \
        r.stdout
    assert "1 rises by 0.00333 every row" in said and "not guessed" not in r.stdout, r.stdout
    channels, _, _ = _imported(tmp_path, src, *maps)
    _same_motion(channels, t, x, F)
    viscous = _written(tmp_path, "viscous.txt", "".join(f"{a:.5f} {1e3 * b:.6f} {2500 * c:.4f} {1e3 * c:.5f}\n"
                                                        for a, b, c in zip(t, x, v)))  # force before velocity
    r = dyno("import", viscous, "--inspect")  # a viscous force follows the rate of change as closely as v does
    assert "--map 'velocity=4:mm/s' --map 'force=3'" in r.stdout, r.stdout
    counted = _written(tmp_path, "counted.txt", "".join(f"{i + 1}  {1e3 * b:.7e}  {c:.7e}\n"
                                                        for i, (b, c) in enumerate(zip(x, F))))
    r = dyno("import", counted, "--inspect")  # no time to read a rate of change by
    assert "guessed from the values" not in r.stdout and "counting the rows, no channel: 1 (1)" in r.stdout
    assert "not guessed from their names or values: 2 (2), 3 (3)" in r.stdout, r.stdout
