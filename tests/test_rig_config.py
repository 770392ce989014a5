"""Rig configuration: the shipped configs load; each mistake is named with its line."""
import pytest

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
