"""A gas charge that warms with the damper: its pressure, and so the gas force, rises
with the body's temperature (or the reservoir's, or the body's through a lag)."""
from __future__ import annotations

from sim_backend.effects.base import Hidden

GAS_LAG_S = 10.0  # s: the lagged form's lag behind the body


class GasTemperature(Hidden):
    name = "gas_temperature"
    listed = 70
    unit = "-"
    form = "share of the body's temperature rise the gas charge takes on"
    guess = 0.1
    hi = 1.0
    forms = {"reservoir": "share of the reservoir's temperature rise (it lags the body by its 60 s)",
             "lagged": "share of the body's temperature rise through a 10 s lag (heat through the floating piston)"}
    repack_K = 0.05  # the gas force follows the temperature closely

    def start(self, pl):
        self.T_lag = pl.T  # K: the body's temperature through GAS_LAG_S

    def warm(self, pl, h):
        self.T_lag += h * (pl.T - self.T_lag) / GAS_LAG_S

    def gas_temperature(self, pl):
        T = {"reservoir": pl.T_res, "lagged": self.T_lag}.get(self.variant, pl.T)
        return pl.T_cell + self.value * (T - pl.T_cell)
