"""Entrained air in the oil: a softer effective bulk modulus (constant; rising with
pressure, eq 3.32; free air compressed isothermally)."""
from __future__ import annotations

import dataclasses

from models.damper import OilCompressibility as Oil
from sim_backend.effects.base import Hidden

P_REF_AIR = 2e6  # Pa: where the air form's effective modulus is VALUE (the pressure form's reference)
K_OIL = 1.37e9  # Pa: pure oil, thesis 3.3.2 (when the damper gives none)


class Compressibility(Hidden):
    name = "compressibility"
    listed = 40
    unit = "Pa"
    form = "effective bulk modulus of the oil (entrained air), constant"
    guess = 2e10
    lo = 1e6
    hi = 1e11
    grows = "inversely"
    weakest = guess / 1e12  # no stiffer than the plain cell's oil (1e12 Pa)
    forms = {"pressure": "bulk modulus rising with chamber pressure (eq 3.32): VALUE / 4 at zero, VALUE at 2 MPa, "
                         "at most 4 VALUE (from 10 MPa)",
             "air": "free air entrained in the oil, compressed isothermally: effective modulus VALUE at 2 MPa, "
                    "softer below, stiffer above"}

    def describe(self, d):
        K = self.value
        if self.variant == "pressure":
            c = Oil(C_ibeta=K / 4, C_sbeta=0.75 * K / P_REF_AIR, beta_min_inv=4 * K)
        elif self.variant == "air":  # 1/K = 1/K_oil + A/P^2 at P_REF_AIR (models/physics/compressibility.py)
            K_oil = d.compressibility.beta_inv or K_OIL
            A = max(P_REF_AIR ** 2 * (1 / K - 1 / K_oil), 0.0)
            c = Oil(beta_inv=K_oil, air_fraction=A / 101325.0)
        else:
            c = Oil(beta_inv=K)
        return dataclasses.replace(d, compressibility=c)

    def start(self, pl):
        if self.variant:  # a modulus that varies tenfold over a cycle: Newton converges on a quarter of the step
            pl.stepper.nsub = 4
