"""Fuzzing every reader of what a user hands dyno: cell files, damper files, protocol
parameters, CSV and MCAP. Whatever the input, the reader gives a valid result or one line
naming the problem (RigError, UsageError, DamperError), never a traceback, never a hang past a few
seconds, and never changes the file it read.

The suite runs a few dozen examples per reader; `make fuzz` runs 10,000 each
(DYNO_FUZZ_EXAMPLES sets the number)."""
import contextlib
import json
import os
import signal
from types import SimpleNamespace

import numpy as np
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from models import damper as dm
from protocols import preflight
from commands import import_csv
from records.reader import load_recording
from protocols.library import PROTOCOLS
from protocols.plan import parse, rig_info
from rig import config as rig_config
from rig.errors import RigError, UsageError

# no explain phase: its tracing slows every call tenfold and a slow call would read as a hang
FUZZ = settings(max_examples=int(os.environ.get("DYNO_FUZZ_EXAMPLES", "30")), deadline=None, database=None,
                suppress_health_check=list(HealthCheck), phases=set(Phase) - {Phase.explain})
HANG_S = 5  # a reader still busy after this long is taken as hung


@contextlib.contextmanager
def within(seconds=HANG_S):
    """Raise TimeoutError in the block after `seconds` (the test fails: a hang)."""
    def ring(*_):
        raise TimeoutError(f"still reading after {seconds} s")
    previous = signal.signal(signal.SIGALRM, ring)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def refused_in_one_line(e):
    assert isinstance(e, (RigError, UsageError, dm.DamperError)), f"{type(e).__name__}: {e}"
    assert str(e) and "\n" not in str(e), repr(str(e))


def read(path, reader, seconds=HANG_S):
    """reader(path) within seconds; (result or None, the refusal or None); the file unchanged."""
    before = path.read_bytes()
    try:
        with within(seconds):
            result, error = reader(path), None
    except (RigError, UsageError, dm.DamperError) as e:
        refused_in_one_line(e)
        result, error = None, e
    assert path.read_bytes() == before, "the reader changed its input"
    return result, error


# values a careless or hostile user types
NUMBERS = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**30, 10**30),
                    st.sampled_from([0, -1, 1e-320, 1e308, 10**400, 0.5, 2]))
WORDS = st.one_of(st.text(max_size=8), st.sampled_from(["", "nan", "inf", "-inf", "1e999", "true", "[]", "{}",
                                                        "0x10", "1,2", ",", "1e-9", "-0"]))


def _edit_lines(text, data):
    """The text with one to three lines replaced, deleted, duplicated or inserted."""
    lines = text.splitlines()
    for _ in range(data.draw(st.integers(1, 3))):
        i = data.draw(st.integers(0, len(lines) - 1))
        what = data.draw(st.sampled_from(["value", "delete", "duplicate", "insert", "garble"]))
        if what == "value" and "=" in lines[i] or what == "value" and ":" in lines[i]:
            sep = "=" if "=" in lines[i] else ":"
            key = lines[i].split(sep)[0]
            value = data.draw(st.one_of(NUMBERS.map(lambda v: json.dumps(v) if not isinstance(v, float) or
                                                    np.isfinite(v) else str(v)),
                                        WORDS.map(json.dumps), WORDS))
            lines[i] = f"{key}{sep} {value}{',' if lines[i].rstrip().endswith(',') else ''}"
        elif what == "delete":
            del lines[i]
        elif what == "duplicate":
            lines.insert(i, lines[i])
        elif what == "insert":
            lines.insert(i, data.draw(st.sampled_from(["stray = 1", '"x": 1,', "[devices.extra]", "[rig]",
                                                       'transport = "serial"', '"name": "again",'])))
        else:
            j = data.draw(st.integers(0, max(len(lines[i]) - 1, 0)))
            lines[i] = lines[i][:j] + data.draw(st.text(max_size=4)) + lines[i][j + 1:]
        if not lines:
            lines = [""]
    return "\n".join(lines) + "\n"


@FUZZ
@given(st.data())
def test_any_cell_file_loads_or_gives_one_line(tmp_path_factory, data):
    name = data.draw(st.sampled_from(["example-cell", "sim-rig", "virtual"]))
    path = tmp_path_factory.mktemp("cell") / "cell.toml"
    path.write_text(_edit_lines(rig_config.path_of(name).read_text(), data))
    cfg, error = read(path, rig_config.load)
    if error is None:
        assert cfg.limits["x_min"] < cfg.limits["x_max"] and cfg.actuator in cfg.devices
        assert set(rig_config.REQUIRED_CHANNELS) <= set(cfg.channels)


@FUZZ
@given(st.data())
def test_any_damper_file_loads_or_gives_one_line(tmp_path_factory, data):
    from models.physics.simulate import simulate
    name = data.draw(st.sampled_from(["koni", "mechformance", "fox-heavy", "simplified-II"]))
    path = tmp_path_factory.mktemp("damper") / "d.json"
    path.write_text(_edit_lines(dm.PRESET_DIR.joinpath(f"{name}.json").read_text(), data))
    d, error = read(path, dm.load_file)
    if error is None and d.layout != "simplified":
        t = np.linspace(0, 0.5, 101)
        x = d.mid_stroke + 0.005 * np.sin(2 * np.pi * 2 * t)
        try:
            with within():
                r = simulate(d, t, x, T=313.15, compressible=False)
        except dm.DamperError as e:
            refused_in_one_line(e)
            return
        assert np.all(np.isfinite(r.force))


PLANNED = ("static", "low-speed", "sine-matrix", "temperature-sweep", "step")


@FUZZ
@given(st.data())
def test_any_protocol_parameters_plan_or_give_one_line(data):
    """parse, the protocol's own check and the pre-flight, as `dyno run` calls them."""
    name = data.draw(st.sampled_from(PLANNED))
    module = PROTOCOLS[name]
    fields = [f for f in module.Params.__dataclass_fields__]
    pairs = data.draw(st.lists(st.tuples(st.sampled_from([*fields, "nope", ""]), st.one_of(
        NUMBERS.map(str), WORDS, st.lists(NUMBERS.map(str), max_size=4).map(",".join))), max_size=4))
    info = _rig_info()
    try:
        with within(HANG_S * 4):  # the pre-flight predicts every segment with the damper model
            params = parse(module.Params, [f"{k}={v}" if k else v for k, v in pairs])
            module.check(params, info)
            f = preflight.check(list(module.plan(params, info)), info)
    except UsageError as e:
        refused_in_one_line(e)
        return
    assert f.duration_s + f.wait_max_s <= preflight.MAX_RUN_S and f.duration_s <= preflight.MAX_MOTION_S


_INFO = []


def _rig_info():
    """The embedded rig's RigInfo, its damper model compiled (numba) before any timing."""
    if not _INFO:
        info = rig_info(rig_config.load("virtual"), dm.load("koni"))
        t = np.linspace(0.0, 0.1, 11)
        info.response(t, info.x_mid + 0.001 * np.sin(20 * t), 0.02 * np.cos(20 * t), 313.15)
        _INFO.append(info)
    return _INFO[0]


CELLS = st.one_of(NUMBERS.map(str), WORDS, st.just(""))


@FUZZ
@given(st.data())
def test_any_csv_imports_or_gives_one_line(tmp_path_factory, data):
    folder = tmp_path_factory.mktemp("csv")
    src = folder / "in.csv"
    header = data.draw(st.lists(st.sampled_from(["t", "x", "F", "T", "v", "", "t"]), min_size=1, max_size=6))
    n = data.draw(st.integers(0, 40))
    regular = data.draw(st.booleans())  # a plausible recording, then spoiled here and there
    rows = []
    for i in range(n):
        row = [str(i * 1e-3) if h == "t" else f"{30 + 5 * np.sin(i / 5):.4f}" if h == "x" else
               f"{100 * np.cos(i / 5):.2f}" if regular else data.draw(CELLS) for h in header]
        if data.draw(st.integers(0, 9)) == 0:
            row[data.draw(st.integers(0, len(row) - 1))] = data.draw(CELLS)
        rows.append(row)
    sep = data.draw(st.sampled_from([",", ";", "\t"]))
    src.write_text(sep.join(header) + "\n" + "\n".join(sep.join(r) for r in rows) + "\n")
    units = data.draw(st.tuples(st.sampled_from(["s", "ms"]), st.sampled_from(["mm", "m", "in"]),
                                st.sampled_from(["N", "kN"])))
    maps = [f"time=t:{units[0]}", f"displacement=x:{units[1]}", f"force=F:{units[2]}"]
    if data.draw(st.booleans()):
        maps.append(data.draw(st.sampled_from(["temperature=T:C", "velocity=v:mm/s", "aux.v=v"])))
    out = folder / "out.mcap"
    args = SimpleNamespace(file=str(src), out=str(out), overwrite=False, map=maps)
    _, error = read(src, lambda p: import_csv.run(args))
    if error is not None:
        assert not out.exists()
        return
    channels, _, _ = load_recording(out)
    assert {"x", "force"} <= set(channels) and all(len(t) == len(v) for t, v in channels.values())


@FUZZ
@given(st.data())
def test_any_force_velocity_table_reads_or_gives_one_line(tmp_path_factory, data):
    """What `check --against TABLE` reads: speeds above zero, compression positive, rebound negative."""
    from records import spec_table
    src = tmp_path_factory.mktemp("spec") / "spec.csv"
    names = data.draw(st.lists(st.sampled_from(["Velocity [mm/s]", "v_m_s", "Speed", "Comp (lbs)", "F_comp_N",
                                                "Rebound [N]", "Zug [daN]", "", "x"]), min_size=1, max_size=5))
    rows = data.draw(st.lists(st.lists(CELLS, min_size=len(names), max_size=len(names)), max_size=12))
    sep = data.draw(st.sampled_from([",", ";", "\t"]))
    src.write_text(sep.join(names) + "\n" + "\n".join(sep.join(r) for r in rows) + "\n")
    got, error = read(src, spec_table.read)
    if error is None:
        assert np.all(got.v_m_s > 0) and np.all(np.diff(got.v_m_s) >= 0)
        assert not np.any(got.F_comp_N < 0) and not np.any(got.F_reb_N > 0)


def _spoil(path, data, how, flips):
    """The file cut short ("cut"), or up to `flips` of its bytes changed ("flip")."""
    raw = bytearray(path.read_bytes())
    if how == "cut":
        raw = raw[:data.draw(st.integers(0, len(raw) - 1))]
    else:
        for _ in range(data.draw(st.integers(1, flips))):
            raw[data.draw(st.integers(0, len(raw) - 1))] = data.draw(st.integers(0, 255))
    path.write_bytes(bytes(raw))


def _good_mcap(folder):
    from tests.mcap_files import good_channels, write
    events = [{"t": 0.0, "kind": "segment_start", "segment": "s1", "params": {"kind": "sine"}},
              {"t": 0.19, "kind": "segment_end", "segment": "s1", "params": {}}]
    return write(folder / "good.mcap", good_channels(), events,
                 {"protocol": {"name": "x", "params": "{}"}, "damper": {"model": ""}})


@FUZZ
@given(st.data())
def test_any_tdms_file_reads_or_gives_one_line(tmp_path_factory, data):
    """A LabVIEW file cut short or with bytes changed: columns of one length, or one line."""
    from nptdms import ChannelObject, TdmsWriter
    from records import tdms
    path = tmp_path_factory.mktemp("tdms") / "run.tdms"
    wave = {"wf_increment": 1e-3, "wf_start_time": np.datetime64("2025-11-14T20:14:37")}
    with TdmsWriter(path) as w:
        w.write_segment([ChannelObject("Dyno", "LVDT", np.arange(50.0), properties={"unit_string": "mm", **wave}),
                         ChannelObject("Dyno", "Load", np.arange(50.0), properties={"unit_string": "N", **wave})])
    _spoil(path, data, data.draw(st.sampled_from(["flip", "cut"])), 8)
    cols, error = read(path, tdms.columns)
    if error is None:
        assert cols and len({len(a) for a in cols.values()}) == 1


JSONISH = st.recursive(st.one_of(st.none(), st.booleans(), NUMBERS.filter(lambda v: not isinstance(v, int) or
                                                                           abs(v) < 10**300), st.text(max_size=5)),
                       lambda inner: st.one_of(st.lists(inner, max_size=4),
                                               st.dictionaries(st.sampled_from(["t", "value", "unit", "kind",
                                                                                "segment", "params"]), inner,
                                                               max_size=5)), max_leaves=12)


@FUZZ
@given(st.data())
def test_any_mcap_reads_or_gives_one_line(tmp_path_factory, data):
    from tests.mcap_files import write
    folder = tmp_path_factory.mktemp("mcap")
    how = data.draw(st.sampled_from(["flip", "cut", "payloads"]))
    if how == "payloads":
        path = write(folder / "x.mcap",
                     {data.draw(st.sampled_from(["force", "x", "T_body"])): data.draw(st.lists(JSONISH, max_size=3))
                      for _ in range(data.draw(st.integers(0, 2)))},
                     data.draw(st.lists(JSONISH, max_size=3)),
                     {data.draw(st.sampled_from(["protocol", "damper", "calibration", "run"])):
                      {data.draw(st.sampled_from(["params", "model", "force", "name"])):
                       data.draw(st.text(max_size=8))}})
    else:
        path = _good_mcap(folder)
        _spoil(path, data, how, 8)
    result, error = read(path, load_recording)
    if error is None:
        channels, events, meta = result
        assert channels and all(len(t) == len(v) and np.all(np.isfinite(t)) for t, v in channels.values())
        assert all(isinstance(e.t, (int, float)) and isinstance(e.kind, str) for e in events)


# issue 42: the run index, its --where parser, the web view's query strings, roads and targets

_RUN_INDEX = []


def _run_index_folder(tmp_path_factory):
    """A folder with two recordings indexed, a check attached: made once, copied by the
    tests that change it."""
    if not _RUN_INDEX:
        from views import run_index
        folder = tmp_path_factory.mktemp("catalogue")
        _good_mcap(folder)
        run_index.index(folder)
        with run_index.beside(folder / "good.mcap") as c:
            c.execute("UPDATE runs SET serial = 'K-12', setup = '{\"clicks\": 12}'")
            c.commit()
        _RUN_INDEX.append(folder)
    return _RUN_INDEX[0]


@FUZZ
@given(st.data())
def test_any_run_index_file_reads_or_gives_one_line(tmp_path_factory, data):
    """A run index file torn, garbled or of another program: read or refused in one line,
    never changed by reading."""
    import shutil
    import sqlite3

    from views import run_index
    folder = tmp_path_factory.mktemp("cat")
    db = folder / run_index.DB_NAME
    how = data.draw(st.sampled_from(["flip", "cut", "foreign", "bytes"]))
    if how == "foreign":
        with contextlib.closing(sqlite3.connect(db)) as c:
            c.execute(f"CREATE TABLE {data.draw(st.sampled_from(['runs', 'peaks', 'other']))} "
                      f"({', '.join(data.draw(st.lists(st.sampled_from(['id', 'path', 'serial', 'x']), min_size=1, max_size=4, unique=True)))})")
            c.commit()
    elif how == "bytes":
        db.write_bytes(data.draw(st.binary(max_size=2048)))
    else:
        shutil.copy(_run_index_folder(tmp_path_factory) / run_index.DB_NAME, db)
        _spoil(db, data, how, 16)

    def look(_):  # as runs list, show and trend and the web view read it
        with run_index.reading(folder) as c:
            rows = run_index.runs(c, serial=data.draw(st.sampled_from([None, "K-12"])))
            for r in rows:
                run_index.run(c, r["id"])
            run_index.trend(c, "K-12", "rebound@0.1m/s")
            return rows
    read(db, look)
    if how in ("foreign", "bytes"):  # not ours: not put in WAL mode, no journal made (ours is in WAL mode)
        assert sorted(p.name for p in folder.iterdir()) == [run_index.DB_NAME]


@FUZZ
@given(st.text(max_size=120) | st.lists(st.tuples(
    st.sampled_from(["serial", "setup.clicks", "setup.a b", "duration_s", "outcome", "nope", "", "id"]),
    st.sampled_from(["=", "!=", "<", "<=", ">", ">=", "~", "==", ""]),
    st.one_of(WORDS, NUMBERS.map(str), st.text(max_size=6).map(lambda s: f'"{s}"'))), max_size=6).map(
    lambda terms: " and ".join(f"{f} {o} {v}" for f, o, v in terms)))
def test_any_where_filter_parses_or_gives_one_line(tmp_path_factory, text):
    """--where: valid SQL the run index runs, or a RunIndexError naming the term."""
    from views import run_index
    folder = _run_index_folder(tmp_path_factory)
    try:
        with run_index.reading(folder) as c, within():
            run_index.runs(c, where=text)
    except run_index.RunIndexError as e:
        refused_in_one_line(e)


_APP = []


def _client(tmp_path_factory):
    if not _APP:
        from views.web import create_app
        app = create_app(_run_index_folder(tmp_path_factory), cache=tmp_path_factory.mktemp("cache"),
                         reindex_s=1e9)
        _APP.append(app.test_client())
    return _APP[0]


@FUZZ
@given(st.sampled_from(["/", "/trend", "/compare", "/qa", "/run/1", "/run/99999999999999999999999", "/live"]),
       st.dictionaries(st.sampled_from(["serial", "since", "protocol", "where", "q", "sort", "desc", "quantity",
                                        "id"]), WORDS | NUMBERS.map(str) | st.text(max_size=30), max_size=4))
def test_any_web_query_gives_a_page_or_a_bad_request(tmp_path_factory, path, query):
    """The browser view's query strings: a page, 400 or 404, never a server error."""
    with within():
        r = _client(tmp_path_factory).get(path, query_string=query)
    assert r.status_code in (200, 400, 404), (path, query, r.status_code)


ROAD_KINDS = st.sampled_from(["step", "sine", "sweep", "iso8608", "file", "nope", ""])


@FUZZ
@given(st.data())
def test_any_road_or_target_reads_or_gives_one_line(tmp_path_factory, data):
    """A road spec (`--road`) and a road or replay target file: a road of bounded length or
    a ParamError naming the problem."""
    from protocols.library import roads
    folder = tmp_path_factory.mktemp("road")
    path = folder / "road.csv"
    if data.draw(st.booleans()):
        rows = data.draw(st.lists(st.tuples(NUMBERS.map(str) | WORDS, NUMBERS.map(str) | WORDS), max_size=12))
        path.write_text("t,y\n" + "\n".join(f"{a},{b}" for a, b in rows) + "\n")
    else:
        path.write_bytes(data.draw(st.binary(max_size=512)))
    kind = data.draw(ROAD_KINDS)
    fields = data.draw(st.lists(NUMBERS.map(str) | WORDS | st.sampled_from(["C", "h", "A"]), max_size=4))
    spec = f"file:{path}" if kind == "file" else ":".join([kind, *fields])
    for reader in (lambda p: roads.parse(spec, 1000.0), lambda p: roads.history(p, "target", "displacement", 1e-3)):
        result, _ = read(path, reader, HANG_S * 12)  # a 600 s random road is 2,000 sinusoids a sample
        if result is not None:
            t = result.t if hasattr(result, "t") else result[0]
            assert len(t) <= preflight.MAX_RUN_S * 1000 + 2000 and np.all(np.isfinite(t))


STAMPS = st.sampled_from(["2025-11-14 20:14:37.917152", "2025-11-14T20:14:37Z", "2025-11-14T20:14:37.5+01:00",
                          "05/13/2022 05:04:23.839 PM", "13/05/2022 05:04:23", "2025-02-30 10:00:00",
                          "12/31/2022 12:00:00.000 AM", "2025-11-14 25:61:00"])


@FUZZ
@given(st.data())
def test_any_foreign_table_imports_or_gives_one_line(tmp_path_factory, data):
    """Another dyno's export (issue 43): a preamble, any delimiter, a decimal comma, date-time
    stamps, a missing or odd header, an events column, spoiled here and there."""
    folder = tmp_path_factory.mktemp("foreign")
    src = folder / data.draw(st.sampled_from(["in.csv", "in.txt"]))
    sep = data.draw(st.sampled_from([",", ";", "\t", "  ", " "]))
    comma = sep != "," and data.draw(st.booleans())
    preamble = data.draw(st.lists(st.sampled_from(["Header Size:  7", "Sampling Rate:  1000", "Sampling Rate: x",
                                                   "Sampling Interval: 0", "Version 2", "", "fs = 300 Hz"]), max_size=4))
    header = data.draw(st.sampled_from([["t", "x", "F"], ["Date/Time", "CHANNEL0", "CHANNEL1", "Events"], []]))
    stamped = data.draw(st.booleans())
    n = data.draw(st.integers(0, 40))
    rows = []
    for i in range(n):
        t = data.draw(STAMPS) if stamped and data.draw(st.integers(0, 9)) == 0 else (
            f"2025-11-14 20:14:{37 + i * 0.01:09.6f}" if stamped else f"{i * 1e-3:.4f}")
        row = [t, f"{30 + 5 * np.sin(i / 5):.4f}", f"{100 * np.cos(i / 5):.2f}"]
        if data.draw(st.integers(0, 9)) == 0:
            row[data.draw(st.integers(0, 2))] = data.draw(CELLS)
        if comma:
            row = [c.replace(".", ",") for c in row]
        rows.append(row + ([data.draw(st.sampled_from(["", "DAQ Start"]))] if len(header) == 4 else []))
    text = "\n".join([*preamble, *([sep.join(header)] if header else []), *(sep.join(r) for r in rows)]) + "\n"
    src.write_text(text)
    names = header or ["1", "2", "3"]
    args = SimpleNamespace(file=str(src), out=str(folder / "out.mcap"), overwrite=False, inspect=False,
                           map=[f"time={names[0]}", f"displacement={names[1]}:mm", f"force={names[2]}:N"],
                           gain=None, offset=None, flip=None, rate=None)
    read(src, lambda p: import_csv.run(SimpleNamespace(**{**vars(args), "inspect": True, "out": None})))
    _, error = read(src, lambda p: import_csv.run(args))
    if error is None:
        channels, _, _ = load_recording(folder / "out.mcap")
        assert {"x", "force"} <= set(channels)
