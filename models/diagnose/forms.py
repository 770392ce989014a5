"""Small forms the baseline and the effects share: a friction's softened sign, a signal
delayed, a part's derivatives scaled, parameters that do not depend on the data."""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from models.diagnose import kernels
from models.diagnose.spec import V_EPS


@kernels.recent
def soft_sign(v: np.ndarray) -> np.ndarray:
    """A friction's direction, softened over V_EPS [m/s]."""
    return np.tanh(v / V_EPS)


@kernels.recent
def shift(y: np.ndarray, t: np.ndarray, tau: float) -> np.ndarray:
    """y [any unit] at t - tau [s] (linear between samples)."""
    return kernels.delayed(np.asarray(y, float)[None, :], np.asarray(t, float), float(tau))[0]


@kernels.recent
def shift_motion(x: np.ndarray, v: np.ndarray, a: np.ndarray, t: np.ndarray, tau: float) -> np.ndarray:
    """The motion x, v, a at t - tau [s] (shift's, one walk for the three): (3, samples)."""
    return kernels.delayed(np.array([x, v, a], float), np.asarray(t, float), float(tau))


def scaled(cols: dict[str, dict[str, np.ndarray]], part: str, g: np.ndarray) -> None:
    """A part multiplied by g: its derivatives too ({part: {parameter: column}}, in place)."""
    cols[part] = {k: c * g for k, c in cols[part].items()}


def fixed(*ps) -> Callable:
    """An effect's parameters, the same whatever the data: Effect.params."""
    return lambda d, e: list(ps)


def temperature_gain(part: str, k: str) -> tuple[Callable, Callable]:
    """(apply, tangent) of a part of the force ("Fd", "Fg") scaled by 1 + k (T - T_m), k
    [1/K] the effect's parameter, T_m the model's mean temperature."""
    def apply(m, d, p, f, e):
        setattr(f, part, getattr(f, part) * (1 + p[k] * (d.T - m.T_m)))

    def tangent(m, d, p, f, e, cols, before):
        dT = d.T - m.T_m
        scaled(cols, part, 1 + p[k] * dT)
        cols[part][k] = before[part] * dT
    return apply, tangent
