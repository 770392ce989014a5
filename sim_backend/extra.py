"""Extra physics a user hides in the virtual plant (`--effect "extra:EXPR"`, `dyno prove
--open EXPR`): a force [N], compression positive, added on the load cell, given as an
expression in the rod's displacement x [m, from full extension], velocity v [m/s], time
t [s] and body temperature T [K], e.g. "2e6 * maximum(x - 0.05, 0)**2" (a bump stop).
Only arithmetic, numbers, those four names, pi and the functions in FUNCS are allowed."""
from __future__ import annotations

import ast
import math

import numpy as np

FUNCS = {n: getattr(np, n) for n in ("sin", "cos", "tan", "exp", "log", "sqrt", "abs", "sign", "tanh", "maximum",
                                     "minimum", "where", "clip")}
NAMES = ("x", "v", "t", "T")
_NODES = (ast.Expression, ast.BinOp, ast.UnaryOp, ast.Compare, ast.Call, ast.Name, ast.Constant, ast.Load,
          ast.operator, ast.unaryop, ast.cmpop)


class ExtraError(ValueError):
    pass


def compile_extra(expr: str):
    """f(x, v, t, T) -> force [N] from the expression; ExtraError names what is wrong."""
    if not expr.strip():
        raise ExtraError(f"extra:{expr}: no force law given (e.g. 2e6*maximum(x-0.05,0)**2)")
    try:
        tree = ast.parse(expr, mode="eval")
    except SyntaxError as e:
        raise ExtraError(f"extra:{expr}: not an expression ({e.msg})") from None
    for node in ast.walk(tree):
        if not isinstance(node, _NODES):
            raise ExtraError(f"extra:{expr}: {type(node).__name__} is not allowed (arithmetic on x, v, t, T only)")
        if isinstance(node, ast.Name) and node.id not in (*NAMES, "pi", *FUNCS):
            raise ExtraError(f"extra:{expr}: unknown name {node.id!r} (use x, v, t, T, pi, {', '.join(FUNCS)})")
        if isinstance(node, ast.Call) and not (isinstance(node.func, ast.Name) and node.func.id in FUNCS):
            raise ExtraError(f"extra:{expr}: only {', '.join(FUNCS)} may be called")
        if isinstance(node, ast.Constant) and not isinstance(node.value, (int, float)):
            raise ExtraError(f"extra:{expr}: only numbers may appear as constants")
    code = compile(tree, "<extra>", "eval")
    scope = {"__builtins__": {}, "pi": math.pi, **FUNCS}

    def force(x, v, t, T):
        return float(eval(code, scope, {"x": x, "v": v, "t": t, "T": T}))  # names and calls checked above
    try:
        F = force(0.05, 0.1, 1.0, 300.0)
    except (ArithmeticError, ValueError, TypeError) as e:
        raise ExtraError(f"extra:{expr}: cannot be evaluated ({e})") from None
    if not math.isfinite(F):
        raise ExtraError(f"extra:{expr}: gives {F} at x = 50 mm, v = 0.1 m/s, t = 1 s, T = 300 K")
    return force
