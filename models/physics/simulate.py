"""Damper force from a motion: arrays in, arrays out.

    r = simulate(damper, t, x, T=C_to_K(94))          # compressible, eq 3.63
    r = simulate(damper, t, x, compressible=False)     # incompressible
    r.force, r.damping, r.gas, r.friction, r.P1, r.P2, r.P_gas

Total force F = F_dT + F_GxT + F_friexT (eq 3.63), positive in compression, N.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from models.physics import assemblies, friction, simplified
from models.damper import Damper, DamperError, SimplifiedDamper
from models.physics.compressibility import P_ATM
from models.physics.kernel import SEATOPEN, pack
from models.physics.stiff import integrate, new_history

ASSEMBLY = assemblies.MODULE
NOUT = 5  # F_d, F_G, P1, P2, P_gas
# Newton tolerance on the stored oil [m^3]: 5e-12 m^3 is about 75 Pa in a 6.7 cc chamber at
# 100 MPa bulk modulus, a force error near 0.1 N.
ATOL_OIL = 5e-12


def oil_atol(damper) -> float:
    """Newton tolerance on the stored oil [m^3]: ATOL_OIL is sized for 100 MPa; a stiffer
    oil needs the stored volume proportionally finer."""
    c, P0 = damper.compressibility, damper.gas_spring.P0
    if c.beta_inv is None:  # eq 3.32 at the gas charge's pressure
        beta = min(c.C_ibeta + c.C_sbeta * P0, c.beta_min_inv)
    else:  # with entrained air, at the gas charge's pressure
        beta = 1.0 / (1.0 / c.beta_inv + c.air_fraction * P_ATM / P0 ** 2)
    return ATOL_OIL * min(1.0, 1e8 / beta)


def C_to_K(T_C):
    return np.asarray(T_C, float) + 273.15


@dataclass
class Simulated:
    t: np.ndarray  # s
    x: np.ndarray  # m, from full extension, compression positive
    v: np.ndarray  # m/s, compression positive
    force: np.ndarray  # N, total (eq 3.63)
    damping: np.ndarray  # N, F_dT
    gas: np.ndarray  # N, F_GxT
    friction: np.ndarray  # N, F_friexT
    P1: np.ndarray  # Pa abs, compression chamber
    P2: np.ndarray  # Pa abs, rebound chamber
    P_gas: np.ndarray  # Pa abs, gas (= chamber 3 in a remote reservoir)
    T: float  # K
    state: tuple | None = None  # (y, seat_open, x_e) to continue a compressible run
    newton_capped: int = 0  # steps whose Newton iteration hit its cap (0 expected)


def simulate(damper, t, x, v=None, T=C_to_K(94.0), compressible=True, x_e=None,
             substeps=1, state=None) -> Simulated:
    """Force response of `damper` to displacement x(t) [m] at temperature T [K].

    t must be uniformly spaced for the compressible model. v defaults to the numerical
    derivative of x. x_e is the rest position the gas equilibrium refers to (eq 4.4);
    it defaults to x[0]. `state` continues an earlier compressible run (Result.state).
    """
    t = np.asarray(t, float)
    x = np.asarray(x, float)
    if t.shape != x.shape or t.ndim != 1 or len(t) < 2:
        raise DamperError("t and x must be 1-D arrays of the same length (>= 2)")
    v = np.gradient(x, t) if v is None else np.asarray(v, float)
    T = float(T)
    if isinstance(damper, SimplifiedDamper):
        Fd = simplified.force(damper, v)
        nan = np.full_like(t, np.nan)
        zero = np.zeros_like(t)
        return Simulated(t, x, v, Fd, Fd, zero, zero, nan, nan, nan, T)
    if not isinstance(damper, Damper):
        raise TypeError("damper must be a Damper or SimplifiedDamper")
    stroke = damper.geometry.stroke
    if x.min() < -1e-9 or x.max() > stroke + 1e-9:
        raise DamperError(f"motion leaves the stroke: x spans {x.min()*1e3:.1f}..{x.max()*1e3:.1f} mm, "
                          f"stroke is 0..{stroke*1e3:.1f} mm")
    if x_e is None:  # a continued run keeps its equilibrium point
        x_e = state[2] if state is not None else float(x[0])
    x_e = float(x_e)
    prm, vp, vh = pack(damper, T, x_e)
    asm = ASSEMBLY[damper.layout]
    out = np.empty((len(t), NOUT))
    capped = 0
    if compressible:
        h = (t[-1] - t[0]) / (len(t) - 1)
        if not np.allclose(np.diff(t), h, rtol=1e-6, atol=1e-12):
            raise DamperError("t must be uniformly spaced for the compressible model")
        if state is None:
            y = asm.initial_state(prm, x[0])
        else:
            y = np.array(state[0], float)
            prm[SEATOPEN] = state[1]
        atol = np.full(asm.NSTATE, oil_atol(damper))
        _, capped, _ = integrate(assemblies.CODE[damper.layout], y, x, v, int(substeps), h, prm, vp, vh, atol,
                                 out, new_history(asm.NSTATE))
        new_state = (y, prm[SEATOPEN], x_e)
    else:
        assemblies.incompressible(assemblies.CODE[damper.layout], x, v, prm, vp, vh, out)
        new_state = None
    f = damper.friction
    if f.x_stick > 0:  # Dahl: the friction builds over x_stick of travel (a continued run restarts it)
        F_c = friction.static_friction(x, f.x_table, f.F_table) * friction.breakaway_ratio(T, f.C_sfT, f.C_ifT)
        Ff = friction.dahl_series(x, F_c, f.x_stick, float(np.sign(v[0]) * F_c[0]))
    else:
        Ff = friction.friction_force(x, v, T, f.x_table, f.F_table, f.C_sfT, f.C_ifT)
    Fd, Fg = out[:, 0], out[:, 1]
    return Simulated(t, x, v, Fd + Fg + Ff, Fd, Fg, Ff, out[:, 2], out[:, 3], out[:, 4], T,
                  new_state, int(capped))


def warm():
    """Compile the damper's kernels in this process, or load them from numba's cache: a
    process pool's or a Dask worker's start (workers/pool.py), so that its first task is not
    charged for it. The quarter car's load on its first sweep."""
    from models.damper import load
    d = load("koni")
    t, x, v = sine(0.002, 2.0, 1, d.mid_stroke, samples_per_cycle=40)
    simulate(d, t, x, v)


def sine(amplitude, freq, cycles, x_mid, samples_per_cycle=None, dt=None):
    """Sinusoidal displacement about x_mid, (t, x, v) for amplitude [m] and freq [Hz].

    It starts at rest at the rebound extreme (x_mid - amplitude) and moves into
    compression, as a servo does, so there is no velocity step at t = 0."""
    if dt is None:
        dt = 1.0 / (freq * (samples_per_cycle or 500))
    n = int(round(cycles / freq / dt)) + 1
    t = np.arange(n) * dt
    w = 2 * np.pi * freq
    return t, x_mid - amplitude * np.cos(w * t), amplitude * w * np.sin(w * t)


class Stepper:
    """The compressible damper advanced one sample at a time, for loops that learn the
    next motion only after this force (the virtual rig, hardware-in-the-loop).

        s = Stepper(koni, T=C_to_K(40), x0=koni.mid_stroke, h=1e-3)
        F, F_d, F_gas, F_fric, P1, P2, P_gas = s.step(x, v)

    BDF2 with its history kept between calls (stiff.py). Motion beyond the stroke is
    clipped (the rig's limits and stops are the caller's business). x_stick > 0 [m]: the
    friction follows Dahl's model (friction.dahl_step) instead of eq 3.3's sgn(v)."""

    def __init__(self, damper: Damper, T, x0, h, x_stick=0.0):
        self.damper, self.h, self.x_e = damper, float(h), float(x0)
        self.x_stick = float(x_stick or damper.friction.x_stick)
        self.F_f = 0.0
        self.nsub = 1  # implicit steps per call
        self.asm = ASSEMBLY[damper.layout]
        self.code = assemblies.CODE[damper.layout]
        self.prm = None
        self.set_temperature(T)
        self.y = self.asm.initial_state(self.prm, self.x_e)
        self.hist = new_history(self.asm.NSTATE)
        self.atol = np.full(self.asm.NSTATE, oil_atol(damper))
        self.xs, self.vs = np.full(2, self.x_e), np.zeros(2)
        self.out = np.zeros((2, NOUT))

    def set_equilibrium(self, x_e):
        """Move the point the polytropic gas law refers to (eq 4.4) [m]: the gas has
        exchanged its heat and is at the cell's temperature there."""
        self.x_e = float(x_e)
        self.set_temperature(self.T, self.T_gas)

    def set_temperature(self, T, T_gas=None):
        """Damper temperature [K]: gas equilibrium and valve coefficients follow; the oil
        held in the chambers (the state) carries over. T_gas: the gas charge's, if not T."""
        seat = None if self.prm is None else self.prm[SEATOPEN]
        self.T_gas = T_gas
        self.prm, self.vp, self.vh = pack(self.damper, float(T), self.x_e, T_gas)
        f = self.damper.friction
        self._fric_table = friction.extended_table(f.x_table, f.F_table)
        self._fric_ratio = float(friction.breakaway_ratio(T, f.C_sfT, f.C_ifT))
        if seat is not None:
            self.prm[SEATOPEN] = seat
        self.T = float(T)

    def step(self, x, v):
        """Forces [N] and pressures [Pa] after moving to x [m] at v [m/s]:
        (total, damping, gas, friction, P1, P2, P_gas)."""
        x = min(max(float(x), 0.0), self.damper.geometry.stroke)
        self.xs[0], self.vs[0] = self.xs[1], self.vs[1]
        self.xs[1], self.vs[1] = x, float(v)
        integrate(self.code, self.y, self.xs, self.vs, self.nsub, self.h, self.prm, self.vp, self.vh, self.atol,
                  self.out, self.hist)
        if self.x_stick > 0:
            self.F_f = Ff = _dahl(x, self.xs[0], *self._fric_table, self._fric_ratio, self.F_f, self.x_stick)
        else:
            f = self.damper.friction
            Ff = float(friction.friction_force(x, v, self.T, f.x_table, f.F_table, f.C_sfT, f.C_ifT))
        # floats, not numpy scalars: the virtual rig's arithmetic on them runs each tick
        Fd, Fg, P1, P2, Pg = self.out[1].tolist()
        return Fd + Fg + Ff, Fd, Fg, Ff, P1, P2, Pg


@njit(cache=True)
def _dahl(x, x0, fx, fF, ratio, F_f, x_stick):
    """Dahl friction [N] after moving from x0 to x [m], from F_f [N]; its magnitude from the
    table fx, fF [m, N] (eq 3.1, clamped at zero) times the breakaway ratio (eq 3.2)."""
    return friction.dahl_step(F_f, x - x0, max(np.interp(x, fx, fF), 0.0) * ratio, x_stick)
