"""Seal friction varying along the bore: sgn(v) B(x), a smooth basis over the stroke."""

from __future__ import annotations

import numpy as np

from models.diagnose import terms
from models.diagnose.forms import soft_sign
from models.diagnose.spec import Effect


FRICTION_KNOTS = 8  # basis functions of position_friction over the stroke


def _position_friction(m, d, p, f, e):
    # extra friction along the stroke, sgn(v) B(x) [N]: a smooth basis over the recorded
    # stroke rather than a law, since a tight spot, a worn band or a step in the bore each
    # have their own shape (the thesis's friction is a constant, eq 3.3)
    B = terms.cached(m, d, e, lambda ref, dd: terms.x_basis(ref, dd, FRICTION_KNOTS))
    f.Ff = f.Ff + (B @ np.array([p[f"pf{i}"] for i in range(B.shape[1])])) * soft_sign(f.v)


def _position_friction_tangent(m, d, p, f, e, cols, before):
    B = terms.cached(m, d, e, lambda ref, dd: terms.x_basis(ref, dd, FRICTION_KNOTS))
    ss = soft_sign(f.v)
    cols["Ff"].update({f"pf{i}": B[:, i] * ss for i in range(B.shape[1])})


EFFECT = Effect(
    "position_friction",
    "seal friction varying along the bore",
    params=lambda d, e: terms.coefficients("pf", FRICTION_KNOTS, terms.force_bound(d)),
    estimate=None,
    apply=_position_friction,
    tangent=_position_friction_tangent,
    acts_on="parts",
    depends_on=("displacement", "direction"),
    linear=True,
    listed=60,
    order=120,
    say=(
        "Friction changes along the stroke ({region}; {size}): a tight spot or wear in the bore or seal. "
        "Inspect the bore and rod.",
        None,
        1.0,
        "N",
    ),
)
