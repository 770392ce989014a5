"""Heat: the damping power warms the body, convection cools it, the reservoir follows the
body; the gas charge exchanges heat towards isothermal at its present position."""
from __future__ import annotations


def gas_temperature(pl):
    """The gas charge's temperature [K]: its share of the body's rise over the cell's (a
    hidden effect may set it otherwise)."""
    for e in pl.hidden:
        T = e.gas_temperature(pl)
        if T is not None:
            return T
    return pl.T_cell + pl.gas_share * (pl.T - pl.T_cell)


def advance(pl, F_d, h):
    """One step of h [s] with the damping force F_d [N] at the mount's velocity."""
    th = pl.p["thermal"]
    power = abs(F_d * pl.v_d)
    pl.energy += power * h
    pl.T += h * (power - th["conductance"] * (pl.T - th["ambient"])) / th["heat_capacity"]
    pl.T_res += h * (pl.T - pl.T_res) / th["reservoir_tau_s"]
    for e in pl.hidden:
        e.warm(pl, h)
    T_gas = gas_temperature(pl)
    if abs(pl.T - pl.T_packed) > pl.repack_K or abs(T_gas - pl.T_gas_packed) > pl.repack_K:  # re-pack as it warms
        pl.stepper.set_temperature(pl.T, T_gas)
        pl.T_packed, pl.T_gas_packed = pl.T, T_gas
        for e in pl.hidden:
            e.repacked(pl)
    # the gas is polytropic about x_gas (eq 4.4) and exchanges heat towards isothermal
    # at its present position over tau (what a static dwell waits for, eq 3.7)
    pl.x_gas += h / th["gas_tau_s"] * (pl.x_d - pl.x_gas)
    if abs(pl.x_gas - pl.stepper.x_e) > 1e-4:
        pl.stepper.set_equilibrium(pl.x_gas)
