"""The two assemblies behind one integer code, so compiled code can choose between them at
run time and still be cached on disk (numba cannot cache a function that takes another
compiled function as an argument or closes over one)."""
from __future__ import annotations

from numba import njit

from models.physics import monotube, remote_reservoir

CODE = {"monotube": 0, "remote_reservoir": 1}
MODULE = {"monotube": monotube, "remote_reservoir": remote_reservoir}


@njit(cache=True)
def rhs(layout, y, x, xd, prm, vp, vh, dydt):
    if layout == 0:
        monotube.rhs(y, x, xd, prm, vp, vh, dydt)
    else:
        remote_reservoir.rhs(y, x, xd, prm, vp, vh, dydt)


@njit(cache=True)
def outputs(layout, y, x, xd, prm, vp, vh, out):
    if layout == 0:
        monotube.outputs(y, x, xd, prm, vp, vh, out)
    else:
        remote_reservoir.outputs(y, x, xd, prm, vp, vh, out)


@njit(cache=True, nogil=True)
def incompressible(layout, x, v, prm, vp, vh, out):
    if layout == 0:
        monotube.incompressible(x, v, prm, vp, vh, out)
    else:
        remote_reservoir.incompressible(x, v, prm, vp, vh, out)
