"""Rig configuration: the shipped configs load; each mistake is named with its line."""
import math

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rig import config
from rig.errors import RigError

BASE = config.CONFIG_DIR.joinpath("virtual.toml").read_text()


def test_shipped_configs_load():
    c = config.load()
    assert c.actuator == "actuator" and {"force", "x", "v", "T_body", "P_gas"} <= set(c.channels)
    assert c.channels["force"].scale(2.0) == pytest.approx(2064.0)
    assert c.channels["T_body"].scale(20.0) == pytest.approx(293.15)
    example = config.load("example-cell")
    assert {d.transport for d in example.devices.values()} == {"can", "serial", "modbus"}


def line_of(text, needle):
    return next(i + 1 for i, ln in enumerate(text.splitlines()) if needle in ln)


@pytest.mark.parametrize("old, new, message, needle", [
    ('device = "loadcell"', 'device = "loadcel"', "channel 'force': unknown device 'loadcel'", 'device = "loadcel"'),
    ('signal = "lvt"', 'signal = "lvdt"', "channel 'v': duplicates channel 'x'", "[channels.v]"),
    ('[channels.x]\ndevice = "conditioner"', '[channels.xx]\ndevice = "conditioner"',
     "required channel 'x' is missing", "[channels]"),
    ('transport = "serial"', 'transport = "rs485"', "unknown transport 'rs485'", 'transport = "rs485"'),
    ('map = "tc-module"', 'map = "tc-modul"', "unknown register map 'tc-modul'", 'map = "tc-modul"'),
    ('signal = "tc2"', 'signal = "tc9"', "device 'tc' has no signal 'tc9'", 'signal = "tc9"'),
    ('unit = "A"', 'unit = "A"\ndrives = "magic"', "'magic' is not one of coil current", 'drives = "magic"'),
    ('unit = "N"', 'unit = "N"\ndrives = "coil current"', "only an aux.* channel drives the damper",
     'drives = "coil current"'),
])
def test_mistakes_name_the_line(old, new, message, needle):
    text = BASE.replace(old, new, 1)
    assert text != BASE
    with pytest.raises(RigError) as e:
        config.parse(text, "cell.toml")
    msg = str(e.value)
    assert message in msg and "\n" not in msg
    if needle != "[channels]":
        assert msg.startswith(f"cell.toml:{line_of(text, needle)}:")


def test_duplicate_table_is_a_toml_error_with_its_line():
    text = BASE + '\n[channels.force]\ndevice = "loadcell"\nsignal = "output"\ngain = 1.0\n'
    with pytest.raises(RigError, match=r"^cell.toml:\d+: "):
        config.parse(text, "cell.toml")


def test_unknown_config_name():
    with pytest.raises(RigError, match="no such rig config"):
        config.load("moon-base")


@pytest.mark.parametrize("old, new, message", [
    ("force_max = 10000.0", "force_max = nan", "limits: force_max: must be a finite number"),
    ("force_max = 10000.0", "force_max = inf", "limits: force_max: must be a finite number"),
    ("force_max = 10000.0", "force_max = -5.0", "limits: force_max: must be above 0"),
    ("force_max = 10000.0", "force_max = 0", "limits: force_max: must be above 0"),
    ("force_max = 10000.0", "force_max = true", "limits: force_max: expected a number, got True"),
    ("force_max = 10000.0", "force_max = 50000.0", "beyond what the actuator declares (force_rating = 35000 N)"),
    ("stale_s = 0.05", "stale_s = 1e9", "limits: stale_s: must be within"),
    ("rate_hz = 1000", "rate_hz = true", "rig: rate_hz: expected a number, got True"),
    ("gain = 1032.0", 'gain = "1032"', "channel 'force': gain: expected a number"),
    ('unit = "N"', 'unit = "kN"', "channel 'force': unit 'kN' is not its SI unit 'N'"),
    ('offset = 273.15         # degC -> K', 'ofset = 273.15', "channel 'T_body': unknown key 'ofset'; did you mean 'offset'?"),
    ("[limits]", "[limit]", "unknown table [limit]; did you mean [limits]?"),
    ("poll_hz = 10", "poll_hz = 0", "device 'tc': poll_hz: must be above 0"),
    ("safe_position = 0.0381", 'safe_position = "0.0381"', "rig: safe_position: expected a number"),
    ("[channels.force]", "[channels]\nfoo = 5\n[channels.force]", "channels.foo: expected a table"),
    ("device_id = 1", "device_id = 1.5", "device 'tc': device_id: expected an integer"),
    ("realtime_priority = 50", "realtime_priority = 100", "rig: realtime_priority: must be within 1..99"),
    ("realtime_priority = 50", "realtime_priority = 1.5", "rig: realtime_priority: expected an integer"),
    ('transport = "serial"', 'transport = "serail"', "unknown transport 'serail'; did you mean 'serial'?"),
])
def test_what_would_switch_safety_off_is_refused_with_its_line(old, new, message):
    text = BASE.replace(old, new, 1)
    assert text != BASE, old
    with pytest.raises(RigError) as e:
        config.parse(text, "cell.toml")
    msg = str(e.value)
    assert message in msg and "\n" not in msg, msg
    line = int(msg.split(":")[1])
    first = next(i + 1 for i, (a, b) in enumerate(zip(text.splitlines(), BASE.splitlines())) if a != b)
    assert line in (first, first + 1), msg  # the edited line (or the key inserted below a header)


def test_a_binary_or_missing_file_is_one_line(tmp_path):
    p = tmp_path / "cell.toml"
    p.write_bytes(bytes(range(256)) * 4)
    with pytest.raises(RigError, match="not a text"):
        config.load(p)
    with pytest.raises(RigError, match="not a file"):
        config.load(tmp_path.as_posix() + "/")


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_any_edit_of_a_config_loads_or_gives_one_line(data):
    """Replace one value of the shipped config by anything TOML can hold: the result is a
    config whose limits are finite and ordered, or a RigError naming a line."""
    lines = BASE.splitlines()
    keys = [i for i, ln in enumerate(lines) if "=" in ln and not ln.lstrip().startswith("#")]
    i = data.draw(st.sampled_from(keys))
    value = data.draw(st.one_of(
        st.floats(allow_nan=True, allow_infinity=True).map(lambda v: repr(v).replace("inf", "inf")),
        st.integers(-10**12, 10**12).map(str), st.booleans().map(lambda b: str(b).lower()),
        st.text(max_size=8).map(lambda s: '"' + s.replace("\\", "").replace('"', "") + '"'),
        st.sampled_from(["[]", "{}", "[1, 2]", '"auto"', "0", "-1", "1e400"])))
    key = lines[i].split("=")[0]
    lines[i] = f"{key}= {value}"
    text = "\n".join(lines)
    try:
        cfg = config.parse(text, "cell.toml")
    except RigError as e:
        assert "\n" not in str(e) and str(e).startswith("cell.toml:")
        return
    L = cfg.limits
    assert all(math.isfinite(v) for v in L.values()) and L["x_min"] < L["x_max"]
    assert L["force_max"] > 0 and 0 < L["stale_s"] <= 1.0
    assert all(math.isfinite(c.gain) and c.gain != 0 for c in cfg.channels.values())


def test_rig_zero_changes_one_offset_and_leaves_the_rest_of_the_file():
    import pytest

    from protocols.commissioning import set_offset
    from rig.errors import UsageError
    text = ('[channels.force]\ndevice = "loadcell"\ngain = 1032.0  # N/V\noffset = 0.0  # tared\nunit = "N"\n\n'
            '[channels.x]\noffset = 0.0381\n')
    out = set_offset(text, "force", -419.8, "dyno rig zero 2026-11-24: tared")
    assert out.splitlines()[3:5] == ["offset = -419.8  # tared", "# dyno rig zero 2026-11-24: tared"]
    assert out.replace("offset = -419.8  # tared\n# dyno rig zero 2026-11-24: tared", "offset = 0.0  # tared") == text
    assert "offset = 0.0381" in set_offset(text, "force", 1.0, "x") and \
        "offset = 0.04\n# y" in set_offset(text, "x", 0.04, "y")
    with pytest.raises(UsageError, match=r"no \[channels.v\] section"):
        set_offset(text, "v", 1.0, "z")


def test_rig_zero_on_the_embedded_rig_reports_and_writes_nothing():
    import subprocess
    import sys
    p = subprocess.run([sys.executable, "-m", "commands.cli", "rig", "zero", "--unloaded", "--x-mm", "38"],
                       capture_output=True, text=True, timeout=300)
    # the virtual damper cannot be disconnected: what the cell reads is its gas force, not a zero error
    assert p.returncode == 1, p.stderr
    assert "force: NOT tared: it reads 4" in p.stdout and "gas force at mid-stroke is 4" in p.stdout
    assert "x: offset 38.100 mm -> 38." in p.stdout and "within 5 %" in p.stdout and "nothing written" in p.stdout


def test_rig_zero_and_rig_check_speak_the_chosen_units(capsys):
    from commands.cli import main
    assert main(["rig", "zero", "--units", "us", "--x-mm", "38.1"]) == 0
    out = capsys.readouterr().out
    # offsets and readings in inches and pounds, to the sensors' resolution (1 um, 0.1 N)
    assert "x: offset 1.50000 in -> 1.5" in out and "where the gauge gave 1.50000 in" in out, out
    assert "force: reads 9" in out and " lbf at rest" in out and "mm" not in out, out
    assert main(["rig", "check", "--units", "us"]) == 0
    out = capsys.readouterr().out
    assert " lbf " in out and " psi " in out and " F " in out and " in/s " in out and " mm" not in out, out
