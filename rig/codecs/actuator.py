"""The actuator controller's modes, states and alarm bits (rig/codecs/dyno.dbc, ACT_CMD and
ACT_STATUS), defined once: the driver, the safety and the emulated controller read them."""

MODES = {"off": 0, "hold": 1, "follow": 2}  # ACT_CMD.mode: valve closed, hold position, follow setpoint
STATES = {0: "off", 1: "holding", 2: "following", 3: "alarm"}  # ACT_STATUS.state
ALARMS = ("hydraulic pressure low", "valve fault", "following error", "interlock open")  # ACT_STATUS.alarm bit i
ALARM_BIT = {name: 1 << i for i, name in enumerate(ALARMS)}


def alarm_texts(bits: int) -> list[str]:
    return [a for i, a in enumerate(ALARMS) if bits >> i & 1]
