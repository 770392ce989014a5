"""Careless and hostile input gets one line naming the problem and exit 2, never a
traceback, and no file already written is lost (issue 17's list, rerun as tests)."""
import contextlib
import io
import json
import os
import socket
import subprocess
import sys
import threading
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from models import damper as dm
from protocols.app import cli, import_csv
from rig.config import CONFIG_DIR
from rig.errors import RigError

DYNO = str(Path(sys.executable).parent / "dyno")
MAP = ["--map", "time=t:s", "--map", "displacement=x:mm", "--map", "force=F:N"]


def dyno(*args):
    """`dyno ARGS` run in this process (the console script's own main: a process each would
    spend most of its time importing); (returncode, stdout, stderr) as a process gives them.
    An exception main lets through fails the test, as a traceback would."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = cli.main([str(a) for a in args])
        except SystemExit as e:  # argparse's usage errors
            code = e.code if isinstance(e.code, int) else 1
    return SimpleNamespace(returncode=code, stdout=out.getvalue(), stderr=err.getvalue())


def one_line_error(p, *words):
    err = p.stderr.strip().splitlines()
    assert p.returncode == 2, p.stderr
    assert "Traceback" not in p.stderr and err and err[-1].startswith("dyno: error: "), p.stderr
    for w in words:
        assert w in err[-1], err[-1]


def csv(tmp_path, rows, name="cell.csv"):
    p = tmp_path / name
    p.write_text("t,x,F\n" + "\n".join(",".join(map(str, r)) for r in rows) + "\n")
    return p


@pytest.fixture()
def files(tmp_path):
    """A binary file, a regular file, a folder, a short recording to keep, and the hostile
    files of HOSTILE beside them."""
    binary = tmp_path / "bin.dat"
    binary.write_bytes(bytes(range(256)) * 8)
    regular = tmp_path / "note.txt"
    regular.write_text("keep me\n")
    rows = [(i * 1e-3, 30 + 5 * np.sin(i / 20), 100 * np.cos(i / 20)) for i in range(200)]
    rec = tmp_path / "kept.mcap"
    p = dyno("import", csv(tmp_path, rows), "--out", rec, *MAP)
    assert p.returncode == 0, p.stderr
    names = {"binary": binary, "regular": regular, "folder": tmp_path, "rec": rec, "csv": tmp_path / "cell.csv"}
    for name, make in HOSTILE.items():
        names[name] = make(tmp_path, rec)
    return SimpleNamespace(names=names, folder=tmp_path, rec=rec, rec_bytes=rec.read_bytes(), regular=regular)


def _damper(tmp, name, **edits):
    """koni.json with edits {"section.field": value} as a file."""
    doc = dm.to_dict(dm.load("koni"))
    for key, value in edits.items():
        *path, last = key.split(".")
        target = doc
        for k in path:
            target = target[k]
        target[last] = value
    out = tmp / name
    out.write_text(json.dumps(doc, indent=1))
    return out


def _cell(tmp, name, edit):
    out = tmp / name
    out.write_text(edit(CONFIG_DIR.joinpath("example-cell.toml").read_text()))
    return out


def _fifo(tmp, name):
    os.mkfifo(tmp / name)
    return tmp / name


def _mcap(name, **kw):
    def make(tmp, rec):
        from tests.mcap_files import good_channels, write
        return write(tmp / name, **{"channels": good_channels(), **kw})
    return make


_SEG = {"t": 0.0, "kind": "segment_start", "segment": "s1", "params": {}}
# name -> maker(tmp folder, kept recording) -> path; each is a case class of issue 28
HOSTILE = {
    "damper_json": lambda t, r: _damper(t, "damper.json"),
    "dup_json": lambda t, r: _write(t / "dup.json", _damper(t, "dup.json").read_text().replace(
        '"name": "koni",', '"name": "koni", "name": "other",')),
    "gas_big": lambda t, r: _damper(t, "gas.json", **{"gas_spring.V0": 5e-3}),
    "cold_ref": lambda t, r: _damper(t, "cold.json", **{"temperature.T_ref": 1e-6}),
    "neg_flow": lambda t, r: _damper(t, "flow.json", **{"valves.piston.rebound.low.C_linpw": -50.0}),
    "big_load": lambda t, r: _damper(t, "load.json", **{"gas_spring.K_voint": 1e6}),
    "huge_int": lambda t, r: _write(t / "huge.json", _damper(t, "huge.json").read_text().replace(
        '"P0": 2510000.0', '"P0": 1' + "0" * 400)),
    "link": lambda t, r: (os.link(r, t / "link.mcap"), t / "link.mcap")[1],
    "sym": lambda t, r: ((t / "sym.mcap").symlink_to(r), t / "sym.mcap")[1],
    "busy": lambda t, r: (_write((t / "busy").mkdir() or t / "busy" / "mine.txt", "mine\n"), t / "busy")[1],
    "fifo_csv": lambda t, r: _fifo(t, "pipe.csv"),
    "fifo_json": lambda t, r: _fifo(t, "pipe.json"),
    "fifo_toml": lambda t, r: _fifo(t, "pipe.toml"),
    "fifo_mcap": lambda t, r: _fifo(t, "pipe.mcap"),
    "long": lambda t, r: t / ("a" * 300 + ".csv"),
    "stray_key": lambda t, r: _cell(t, "stray.toml", lambda s: "stray = 1\n" + s),
    "two_ports": lambda t, r: _cell(t, "ports.toml", lambda s: s + '\n[devices.lc2]\ntransport = "serial"\n'
                                    'port = "/dev/serial/by-id/usb-LOADCELL-AMP-if00"\n'),
    "two_nodes": lambda t, r: _cell(t, "nodes.toml", lambda s: s + '\n[devices.daq2]\ntransport = "can"\n'
                                    'interface = "socketcan"\nchannel = "can0"\nnode = "daq"\n'),
    "two_ids": lambda t, r: _cell(t, "ids.toml", lambda s: s.replace('host = "ai-module.cell2.local"',
                                                                     'host = "tc-module.cell2.local"')),
    "map_dir": lambda t, r: ((t / "maps.toml").mkdir(), _cell(t, "mapdir.toml", lambda s: s.replace(
        'map = "tc-module"', f'map = "{t}/maps.toml"')))[1],
    "dup_regs": lambda t, r: (_write(t / "regs.toml", CONFIG_DIR.parent.joinpath(
        "codecs/registers/tc-module.toml").read_text().replace("[values.tc2]\naddress = 2",
                                                               "[values.tc2]\naddress = 1")),
        _cell(t, "dupregs.toml", lambda s: s.replace('map = "tc-module"', f'map = "{t}/regs.toml"')))[1],
    "mismatch": _mcap("mismatch.mcap", channels={"force": [{"t": [0.0, 0.001, 0.002], "value": [1.0, 2.0]}]}),
    "strings": _mcap("strings.mcap", channels={"force": [{"t": [0.0, 0.001], "value": ["a", "b"]}]}),
    "bad_meta": _mcap("meta.mcap", metadata={"protocol": {"name": "x", "params": "{not json"}}),
    "no_segment": _mcap("noseg.mcap", events=[{"t": 0.0, "kind": "segment_start", "params": {}}]),
    "foreign": _mcap("foreign.mcap", channels={}, topics={"/camera": [b"\x00\x01"]}),
}


def _write(path, text):
    path.write_text(text)
    return path


CASES = [
    (["rig", "check", "--rig", "{binary_toml}"], ["not a text"]),
    (["run", "sine-matrix", "--damper", "{binary_json}"], ["not a text (JSON) file"]),
    (["import", "{binary_csv}", "--out", "{folder}/b.mcap", *MAP], ["not a text (CSV) file"]),
    (["run", "sine-matrix", "--out", "/dev/full"], ["not a regular file"]),
    (["run", "sine-matrix", "--out", "{regular}/x.mcap"], ["note.txt is a file, not a folder"]),
    (["run", "sine-matrix", "--out", "{regular}/deeper/x.mcap"], ["cannot create its folder (Not a directory)"]),
    (["run", "sine-matrix", "--out", "{rec}"], ["exists; give --overwrite"]),
    (["report", "{rec}", "--out", "{regular}"], ["exists and is not a folder"]),
    (["plot", "damper", "koni", "--out", "{regular}"], ["exists and is not a folder"]),
    (["identify", "{rec}", "--out", "{regular}/m.json"], ["is a file, not a folder"]),
    (["identify", "{rec}", "--report", "{regular}"], ["exists and is not a folder"]),
    (["diagnose", "{rec}", "--report", "{regular}"], ["exists and is not a folder"]),
    (["export", "{rec}", "--csv", "{regular}"], ["exists; give --overwrite"]),
    (["export", "{rec}", "--csv", "{rec}", "--overwrite"], ["that is an input of this command"]),
    (["export", "{rec}", "--csv", "{folder}/t.csv", "--channels", "force,nope"], ["no channel 'nope'"]),
    (["rig", "zero", "--rig", "{binary_toml}"], ["not a text"]),
    (["recover", "{folder}"], ["not a file"]),
    (["report", "{binary}", "--out", "{folder}/r"], ["not a readable recording"]),
    (["identify", "{folder}"], ["a folder, not a file"]),
    (["identify"], ["give RECORDING..., or --batch FILE..."]),
    (["identify", "--batch", "{rec}", "--out", "{folder}/m.json"], ["--out, --report and --truth are for a single"]),
    (["diagnose", "--batch", "{folder}/nope.mcap"], ["--batch: ", "nope.mcap: no such file"]),
    (["diagnose", "--batch", "{rec}", "--summary", "{rec}"], ["that is an input of this command"]),
    (["import", "{rec}", "--out", "{folder}/c.mcap", *MAP], ["not a text (CSV) file"]),
    (["run", "sine-matrix", "amplitudes_mm=30", "freqs_hz=16"], ["nothing to run: every combination is skipped"]),
    (["run", "sine-matrix", "amplitudes_mm="], ["amplitudes_mm: needs at least one value"]),
    (["run", "sine-matrix", "freqs_hz=nan"], ["freqs_hz: 'nan' is not a finite number"]),
    (["run", "sine-matrix", "freqs_hz=1e-6"], ["more than 2.0 h", "--long"]),
    (["run", "static", "approach_mm=50"], ["approach_mm: 50 mm leaves no stroke"]),
    (["run", "step", "steps_mm=5", "hold_s=inf"], ["hold_s: 'inf' is not a finite number"]),
    (["sim-rig", "--config", "{binary_toml}"], ["not a text"]),
    (["sim-rig", "--fault", "can_bus_off@nan"], ["the time after @ must be seconds"]),
    (["run", "sine-matrix", "--damper", "simplified-I"], ["a simplified model"]),
    (["run", "sine-matrix", "--seed", "-5"], ["run: argument --seed: must be within"]),
    (["run", "sine-matrix", "--rrd", "{regular}/x.rrd"], ["note.txt is a file, not a folder"]),
    (["run", "static", "points=100000"], ["points: 2 to 200"]),
    (["run", "temperature-sweep", "overshoot_c=-50"], ["overshoot_c: must not be negative"]),
    (["bench", "diagnose", "--rate", "0"], ["bench diagnose: argument --rate: must be above 0"]),
    (["bench", "identify", "{binary}"], ["not a readable recording"]),
    (["bench", "identify", "--damper", "nosuch"], ["recording nosuch: unknown damper preset 'nosuch'"]),
    (["prove", "--effects", "gremlins"], ["unknown effect 'gremlins'"]),
    (["validate", "--json", "extra"], ["unrecognized arguments: extra"]),
    (["diagnose", "{rec}", "--next", "--budget", "-5"], ["--budget: must be a positive number of seconds"]),
    (["runs", "list", "{regular}"], ["no such folder of recordings"]),
    (["diagnose", "{rec}", "--next", "--rig", "nosuch"], ["nosuch: no such rig config"]),
    (["validate", "--report", "{regular}"], ["exists and is not a folder"]),
    (["diagnose", "{rec}", "--next", "--baseline", "koni"], ["--next designs from the minimal baseline"]),
    # issue 28: outputs never lose an input or an existing file
    (["identify", "{rec}", "--out", "{rec}"], ["that is an input"]),
    (["identify", "{rec}", "--damper", "{damper_json}", "--out", "{damper_json}", "--overwrite"], ["that is an input"]),
    (["identify", "{rec}", "--out", "{regular}"], ["exists; give --overwrite"]),
    (["import", "{csv}", "--out", "{csv}", "--overwrite", *MAP], ["that is an input"]),
    (["report", "{rec}", "--out", "{folder}", "--overwrite"], ["holds the input"]),
    (["report", "{rec}", "--out", "{busy}"], ["not empty; give --overwrite"]),
    (["plot", "damper", "{damper_json}", "--out", "{folder}"], ["holds the input"]),
    (["plot", "damper", "koni", "--out", "{busy}"], ["not empty; give --overwrite"]),
    (["diagnose", "{rec}", "--report", "{folder}"], ["holds the input"]),
    (["export", "{rec}", "--csv", "{link}", "--overwrite"], ["that is an input"]),
    (["export", "{rec}", "--csv", "{sym}", "--overwrite"], ["that is an input"]),
    (["export", "{link}", "--csv", "{rec}", "--overwrite"], ["that is an input"]),
    (["export", "{rec}", "--csv", "{long}"], ["file name too long"]),
    (["run", "sine-matrix", "--damper", "{damper_json}", "--out", "{damper_json}", "--overwrite"],
     ["that is an input"]),
    (["run", "sine-matrix", "--damper", "{damper_json}", "--rrd", "{damper_json}", "--overwrite"],
     ["that is an input"]),
    # nonsense refused, naming the field, the value and the range
    (["run", "sine-matrix", "--damper", "{gas_big}"], ["gas_spring.V0: 0.005 m^3 of gas is more than 2 x the oil"]),
    (["run", "sine-matrix", "--damper", "{cold_ref}"], ["temperature.T_ref: 1e-06 K is outside 200..450 K"]),
    (["run", "sine-matrix", "--damper", "{neg_flow}"], ["rebound.low.C_linpw: -50 N s/m is outside 0..1e+06"]),
    (["run", "sine-matrix", "--damper", "{big_load}"], ["gas_spring.K_voint: 1e+06 m^3 is outside"]),
    (["run", "sine-matrix", "--damper", "{huge_int}"], ["gas_spring.P0: must be finite"]),
    (["run", "sine-matrix", "--damper", "{dup_json}"], ["key 'name' given twice"]),
    (["run", "sine-matrix", "freqs_hz=1", "freqs_hz=2"], ["freqs_hz: given twice"]),
    (["run", "hil", "car=race-car", "--car", "simulator"], ["car: given twice"]),
    (["run", "static", "dwell_max_s=1e9"], ["the plan may run for", "--long"]),
    (["rig", "check", "--rig", "{stray_key}"], ["stray.toml:1: unknown key 'stray'"]),
    (["rig", "check", "--rig", "{two_ports}"], ["device 'lc2'", "taken by device 'loadcell'"]),
    (["rig", "check", "--rig", "{two_nodes}"], ["device 'daq2'", "node daq is taken by device 'conditioner'"]),
    (["rig", "check", "--rig", "{two_ids}"], ["device 'analog'", "id 1 is taken by device 'tc'"]),
    (["rig", "check", "--rig", "{map_dir}"], ["maps.toml: not a file"]),
    (["rig", "check", "--rig", "{dup_regs}"], ["values.tc2: register 1 also holds values.tc1"]),
    # readers that distrust their input
    (["import", "{fifo_csv}", "--out", "{folder}/f.mcap", *MAP], ["not a regular file"]),
    (["run", "sine-matrix", "--damper", "{fifo_json}"], ["not a regular file"]),
    (["rig", "check", "--rig", "{fifo_toml}"], ["not a file"]),
    (["report", "{fifo_mcap}", "--out", "{folder}/r"], ["not a regular file"]),
    (["export", "{mismatch}", "--csv", "{folder}/m.csv"], ["/channels/force: a message with 3 times and 2 values"]),
    (["report", "{strings}", "--out", "{folder}/r"], ["/channels/force: values are not numbers"]),
    (["identify", "{bad_meta}"], ["metadata protocol.params: not JSON"]),
    (["diagnose", "{no_segment}"], ["/events: an event without its fields"]),
    (["report", "{foreign}", "--out", "{folder}/r"], ["no dyno channels"]),
]


@pytest.mark.parametrize("args, words", CASES, ids=[" ".join(a[:2]) + f" {i}" for i, (a, _) in enumerate(CASES)])
def test_bad_input_is_one_line_and_loses_nothing(files, args, words):
    t = files.folder
    names = dict(files.names)
    for ext in ("toml", "json", "csv"):
        p = t / f"bin.{ext}"
        p.write_bytes(names["binary"].read_bytes())
        names[f"binary_{ext}"] = p
    before = {p: p.read_bytes() for p in t.rglob("*") if p.is_file() and not p.is_symlink()}
    p = dyno(*[a.format(**names) for a in args])
    one_line_error(p, *words)
    assert {p: p.read_bytes() for p in before if p.exists()} == before  # nothing changed, nothing gone
    assert files.rec.read_bytes() == files.rec_bytes and files.regular.read_text() == "keep me\n"
    left = [p.name for p in t.rglob("*") if p.name.endswith((".partial", ".lock"))]
    assert not left, left


@pytest.mark.parametrize("rows, words", [
    ([(0.0, 1, 1)] * 20, ["the time column 't' does not advance"]),
    ([(i * 1e-3, 30, 1e300 if i == 5 else 1) for i in range(20)], [":7: column 'F'", "not a plausible force"]),
    ([(i * 1e-3, "inf" if i == 3 else 30, 1) for i in range(20)], [":5: column 'x': 'inf' is not a finite number"]),
    ([(i * 1e-3, 30, "") for i in range(20)], ["column 'F' (force) holds 0 numbers", "needs at least 10"]),
    ([(i * 1e-3, 30, 5 if i == 7 else "") for i in range(20)], ["column 'F' (force) holds 1 number "]),
])
def test_bad_csv_values_are_refused_with_their_row(tmp_path, rows, words):
    p = dyno("import", csv(tmp_path, rows), "--out", tmp_path / "x.mcap", *MAP)
    one_line_error(p, *words)
    assert not (tmp_path / "x.mcap").exists()


def test_network_waits_end_with_the_endpoint_named(tmp_path):
    """A TCP port that accepts and never speaks, and one with nothing behind it."""
    server = socket.create_server(("127.0.0.1", 0))
    port = server.getsockname()[1]
    held = []
    threading.Thread(target=lambda: held.append(server.accept()), daemon=True).start()
    text = CONFIG_DIR.joinpath("sim-rig.toml").read_text()
    silent = tmp_path / "silent.toml"
    silent.write_text(text.replace("29536", str(port)))
    p = dyno("rig", "check", "--rig", silent)
    one_line_error(p, f"socketcand at 127.0.0.1:{port} did not answer in 2 s")
    server.close()
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        free = s.getsockname()[1]
    closed = tmp_path / "closed.toml"
    closed.write_text(text.replace("29536", str(free)))
    p = dyno("run", "sine-matrix", "--rig", closed, "--out", tmp_path / "x.mcap")
    one_line_error(p, f"no socketcand at 127.0.0.1:{free}")
    assert not (tmp_path / "x.mcap").exists()


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                  HealthCheck.function_scoped_fixture])
@given(st.lists(st.lists(st.one_of(st.floats(), st.integers(), st.text(max_size=6),
                                   st.sampled_from(["", "nan", "inf", "-1e308", "1e-320"])),
                         min_size=0, max_size=4), max_size=30))
def test_any_csv_imports_or_gives_one_line(tmp_path_factory, rows):
    """Whatever the rows, `dyno import` writes a recording or refuses with a RigError."""
    t = tmp_path_factory.mktemp("csv")
    src = t / "in.csv"
    src.write_text("t,x,F\n" + "\n".join(",".join(str(v).replace(",", ";") for v in r) for r in rows))
    args = SimpleNamespace(file=str(src), out=str(t / "out.mcap"), overwrite=False,
                           map=["time=t:s", "displacement=x:mm", "force=F:N"])
    try:
        import_csv.run(args)
    except RigError as e:
        assert "\n" not in str(e)
        assert not (t / "out.mcap").exists()
        return
    assert (t / "out.mcap").stat().st_size > 0


def _leaves(obj, path=()):
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from _leaves(v, path + (k,))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            yield from _leaves(v, path + (i,))
    else:
        yield path


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_any_edit_of_a_damper_json_loads_or_gives_one_line(data):
    """One value of a preset replaced by anything JSON holds: the model loads and gives
    finite forces, or the loader names the field."""
    from models.physics.simulate import simulate
    name = data.draw(st.sampled_from(["koni", "mechformance", "fox-heavy"]))
    doc = dm.to_dict(dm.load(name))
    path = data.draw(st.sampled_from(list(_leaves(doc))))
    value = data.draw(st.one_of(st.floats(), st.integers(-10**9, 10**9), st.text(max_size=5), st.none(),
                                st.booleans(), st.just([]), st.just({})))
    target = doc
    for k in path[:-1]:
        target = target[k]
    target[path[-1]] = value
    try:
        d = dm.from_dict(json.loads(json.dumps(doc)))
    except dm.DamperError as e:
        assert "\n" not in str(e)
        return
    if d.layout == "simplified":
        return
    t = np.linspace(0, 0.5, 101)
    x = d.mid_stroke + 0.005 * np.sin(2 * np.pi * 2 * t)
    try:
        r = simulate(d, t, x, T=313.15, compressible=False)
    except dm.DamperError as e:
        assert "\n" not in str(e)
        return
    assert np.all(np.isfinite(r.force))


def test_a_zero_pressure_slope_of_the_bulk_modulus_is_named():
    """Found by the test above: eq 3.32 with C_sbeta = 0 divided by zero at its cap."""
    doc = dm.to_dict(dm.load("fox-heavy"))
    assert doc["compressibility"].get("C_sbeta") is not None
    doc["compressibility"]["C_sbeta"] = 0.0
    with pytest.raises(dm.DamperError, match="compressibility.C_sbeta: must be positive"):
        dm.from_dict(doc)

@pytest.mark.realtime
def test_two_runs_on_one_file_and_a_failed_start_lose_nothing(tmp_path, files):
    """A second writer of the same file is refused while the first runs; a run that fails
    before it starts leaves the file it was asked to overwrite as it was."""
    out = tmp_path / "busy.mcap"
    first = subprocess.Popen([DYNO, "run", "sine-matrix", "--realtime", "--out", str(out), "amplitudes_mm=3.2",
                              "freqs_hz=2", "record_cycles=6"], stderr=subprocess.PIPE, text=True)
    try:
        while "recording to" not in first.stderr.readline():
            pass
        one_line_error(dyno("run", "sine-matrix", "--out", out, "--overwrite"), "another run is writing it")
    finally:
        rest = first.communicate(timeout=120)[1]
    assert first.returncode == 0, rest
    p = dyno("report", out, "--out", tmp_path / "rep")
    assert p.returncode == 0, p.stderr
    # overwrite asked, but the rig never opens: the old recording stays
    closed = tmp_path / "closed.toml"
    closed.write_text(CONFIG_DIR.joinpath("sim-rig.toml").read_text().replace("29536", "1"))
    before = files.rec.read_bytes()
    one_line_error(dyno("run", "sine-matrix", "--rig", closed, "--out", files.rec, "--overwrite"), "no socketcand")
    assert files.rec.read_bytes() == before
    assert not [p for p in files.folder.iterdir() if p.name.endswith((".partial", ".lock"))]


def test_identify_creates_its_output_folder_before_the_work(tmp_path, files):
    out = tmp_path / "new" / "deeper" / "m.json"
    p = dyno("identify", files.rec, "--out", out)
    assert out.parent.is_dir()  # made before identification ran (which may refuse this tiny import)
    assert "Traceback" not in p.stderr
    if p.returncode == 0:
        assert out.exists()
    else:
        one_line_error(p)


def test_recover_twice_never_overwrites_a_damaged_original(tmp_path, files):
    data = files.rec.read_bytes()
    bad = tmp_path / "torn.mcap"
    for i in range(2):
        bad.write_bytes(data[:-100])  # the summary torn off, as by a kill
        p = dyno("recover", bad)
        assert p.returncode == 0 and "recovered" in p.stdout, p.stderr
    damaged = sorted(x.name for x in tmp_path.glob("torn.mcap.damaged*"))
    assert damaged == ["torn.mcap.damaged", "torn.mcap.damaged-2"]
    assert os.path.getsize(tmp_path / "torn.mcap.damaged") == len(data) - 100
