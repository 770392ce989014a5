"""A damper model as plain data: dataclasses that round-trip through JSON.

All values are SI (Pa absolute, m, m^2, m^3, K, N, N s/m). Parameter names follow the
thesis symbols in ASCII; docs/damper-json.md documents every field. Loading checks
completeness and physical sense and raises DamperError naming the field.
"""
from __future__ import annotations

import dataclasses
import json
import math
import types
import typing
from dataclasses import dataclass
from pathlib import Path


PRESET_DIR = Path(__file__).parent / "presets"
T_STD = 293.15  # K: the thesis's 20 C reference its temperature coefficients are taken from (eq 3.2, 4.4)
T_MAX_RATED = 423.15  # K (150 C): top of the thesis's racing-damper temperature range


T_MIN_RATED = 233.15  # K (-40 C): the coldest a damper is stored or tested at
LOW_BRANCH_MIN = 1.0  # N at 1 m/s: the always-open restriction of the weakest valve (Fox head: 150)
X_TABLE_STEP = 1e-6  # m: the friction table's closest entries (a 2e-309 step made its end slope overflow)
GAS_TO_OIL_MAX = 2.0  # gas volume V0 over oil volume V_total: the presets span 0.34-1.04


class DamperError(ValueError):
    """A damper description that is incomplete, malformed or non-physical."""


def q(unit, lo, hi, default=dataclasses.MISSING):
    """A field's SI unit and physical range [lo, hi], declared beside it; build() refuses a
    value outside, naming the field, the value and the range."""
    return dataclasses.field(default=default, metadata={"unit": unit, "range": (lo, hi)})


@dataclass
class Geometry:
    A_p: float = q("m^2", 1e-5, 1e-2)  # piston area (bore 3.6-113 mm)
    A_r: float = q("m^2", 1e-6, 5e-3)  # rod area
    stroke: float = q("m", 1e-3, 1.0)  # usable stroke from full extension
    V_total: float = q("m^3", 1e-7, 1e-2)  # oil volume of chambers 1 + 2 at full extension (Tables 4.5-4.8)
    V20: float = q("m^3", 1e-9, 1e-2)  # chamber 2 (rebound side) volume at full extension

    @property
    def A_w(self) -> float:
        """Working area of the piston valves, A_p - A_r [m^2] (eq 3.33)."""
        return self.A_p - self.A_r


@dataclass
class GasSpring:
    P0: float = q("Pa", 1e4, 2e7)  # charge pressure at full extension and T0, absolute (Table 4.1)
    V0: float = q("m^3", 1e-8, 1e-2)  # gas volume at full extension and T0 (Table 4.1)
    T0: float = q("K", 200.0, 450.0)  # charge temperature
    gamma: float = q("-", 1.0, 1.67)  # polytropic exponent, isothermal to adiabatic (4.2.2.2)
    K_voil: float = q("m^3/K", -1e-5, 1e-5)  # effective thermal expansion (Table 4.4)
    K_voint: float = q("m^3", -1e-3, 1e-3)  # regression intercept (Table 4.4)


@dataclass
class Friction:
    x_table: list[float] = q("m", -1.0, 2.0)  # displacements (eq 3.1)
    F_table: list[float] = q("N", 0.0, 1e4)  # static breakaway friction at 20 C (eq 3.1)
    C_sfT: float = q("1/K", -0.1, 0.1)  # temperature slope of the breakaway ratio (Table 4.2)
    C_ifT: float = q("-", 0.0, 20.0)  # breakaway ratio at 20 C (Table 4.2, or Table 4.3 mean)
    # pre-sliding travel of Dahl's model (friction.dahl_step); 0: eq 3.3's sgn(v)
    x_stick: float = q("m", 0.0, 1e-3, 0.0)


@dataclass
class Branch:
    """One restriction in weighted form F = C_orrpw v^2 + C_linpw v + C_ipw (eq 4.14);
    an orifice has C_linpw = 0, a flow-compensating valve C_orrpw = 0 (eqs 4.12, 4.13)."""
    C_orrpw: float = q("N s^2/m^2", -1e8, 1e8, 0.0)  # sign of the direction
    C_linpw: float = q("N s/m", 0.0, 1e6, 0.0)
    C_ipw: float = q("N", -1e4, 1e4, 0.0)  # constant / cracking force


@dataclass
class Line:
    """A linear valve F = C_linw v + C_ilinw (eq 4.13): passes flow beyond |C_ilinw|."""
    # at least a valve's weakest low branch: a vanishing slope passes an unbounded flow
    # (2e-309 gave NaN forces), and the range bounds an identification's fit (a flat high line)
    C_linw: float = q("N s/m", LOW_BRANCH_MIN, 1e6)
    C_ilinw: float = q("N", -1e5, 1e5)


@dataclass
class Direction:
    low: Branch  # always-open low-speed restriction
    mid: Line | None = None  # mid-speed valve in parallel (eq 3.30)
    high: Line | None = None  # replaces `mid` beyond the crossover flow (Fox-heavy)


@dataclass
class ValvePath:
    compression: Direction
    rebound: Direction


@dataclass
class Bypass:
    """Mis-seated bypass disc (eqs 4.15-4.16): open while F = dP12 A_w > dP_seat_Aw."""
    # open, the bypass passes F / C_seatw of flow (eq 4.16): at least a valve's weakest low branch,
    # or a vanishing coefficient passes an unbounded flow (a subnormal 2e-309 gave NaN forces)
    C_seatw: float = q("N s/m", LOW_BRANCH_MIN, 1e6)
    dP_seat_Aw: float = q("N", -1e5, 1e5)  # seating force


@dataclass
class Valves:
    piston: ValvePath
    head: ValvePath | None = None  # compression head (remote reservoir only)
    bypass: Bypass | None = None


@dataclass
class OilCompressibility:
    """Constant effective bulk modulus beta_inv, or eq 3.32: K = C_ibeta + C_sbeta P
    capped at beta_min_inv. Set either beta_inv or the three others. With beta_inv,
    air_fraction > 0 adds free air entrained in the oil (models/physics/compressibility.py)."""
    beta_inv: float | None = q("Pa", 1e5, 1e13, None)  # 1e12 and above: incompressible
    C_ibeta: float | None = q("Pa", 1e5, 1e11, None)
    C_sbeta: float | None = q("-", 0.0, 1e4, None)
    beta_min_inv: float | None = q("Pa", 1e5, 1e11, None)
    air_fraction: float = q("-", 0.0, 0.2, 0.0)  # free air per volume of oil at atmospheric pressure


@dataclass
class TempCoeff:
    K_effoil: float = q("1/K", -1.0, 1.0)  # (Table 4.10, eq 4.17)
    C_fd: float = q("-", -10.0, 10.0)


@dataclass
class TemperatureSensitivity:
    T_ref: float = q("K", 200.0, 450.0)  # temperature the valve coefficients refer to
    compression: TempCoeff
    rebound: TempCoeff


@dataclass
class Damper:
    name: str
    layout: str  # "monotube" | "remote_reservoir"
    geometry: Geometry
    gas_spring: GasSpring
    friction: Friction
    valves: Valves
    compressibility: OilCompressibility
    temperature: TemperatureSensitivity
    description: str = ""
    x_mid: float | None = q("m", 0.0, 1.0, None)  # default equilibrium point; mid-stroke if None

    @property
    def mid_stroke(self) -> float:
        return self.geometry.stroke / 2 if self.x_mid is None else self.x_mid


@dataclass
class SimplifiedDirection:
    c_low: float = q("N s/m", 0.0, 1e6)  # low-speed damping coefficient
    c_mid: float = q("N s/m", 0.0, 1e6)  # mid-speed damping coefficient
    v_transition: float | None = q("m/s", -10.0, 10.0, None)  # transition velocity (alpha, eq 6.2)


@dataclass
class SimplifiedDamper:
    """Piecewise-linear asymmetric damping, eqs 6.1 (model I) and 6.2 (model II)."""
    name: str
    layout: str  # "simplified"
    compression: SimplifiedDirection
    rebound: SimplifiedDirection
    description: str = ""


# --- JSON ---------------------------------------------------------------------------------

def build(cls, data, where=""):
    """A dataclass `cls` from JSON data, naming any missing, unknown or mistyped field."""
    if not isinstance(data, dict):
        raise DamperError(f"{where or 'damper'}: expected an object, got {type(data).__name__}")
    hints = typing.get_type_hints(cls)
    names = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(data) - names)
    if unknown:
        raise DamperError(f"{where + '.' if where else ''}{unknown[0]}: unknown field")
    kwargs = {}
    for f in dataclasses.fields(cls):
        path = f"{where}.{f.name}" if where else f.name
        if f.name not in data:
            if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
                raise DamperError(f"{path}: missing")
            continue
        kwargs[f.name] = _value(hints[f.name], data[f.name], path)
    return cls(**kwargs)


def _value(tp, value, path):
    args = typing.get_args(tp)
    if typing.get_origin(tp) in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        tp = next(a for a in args if a is not type(None))
        return _value(tp, value, path)
    if dataclasses.is_dataclass(tp):
        return build(tp, value, path)
    if typing.get_origin(tp) is list:
        if not isinstance(value, list):
            raise DamperError(f"{path}: expected a list")
        return [_value(args[0], v, f"{path}[{i}]") for i, v in enumerate(value)]
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise DamperError(f"{path}: expected a number, got {value!r}")
        try:
            out = float(value)
        except OverflowError:  # an integer beyond any float
            out = float("inf")
        if not math.isfinite(out):
            raise DamperError(f"{path}: must be finite")
        return out
    if tp is str:
        if not isinstance(value, str):
            raise DamperError(f"{path}: expected a string")
        return value
    raise TypeError(tp)


def from_dict(data) -> Damper | SimplifiedDamper:
    if not isinstance(data, dict):
        raise DamperError("damper: expected a JSON object")
    layout = data.get("layout")
    if layout == "simplified":
        model = build(SimplifiedDamper, data, "")
    elif layout in ("monotube", "remote_reservoir"):
        model = build(Damper, data, "")
    else:
        raise DamperError(f"layout: must be monotube, remote_reservoir or simplified, got {layout!r}")
    check(model)
    return model


def to_dict(model) -> dict:
    return dataclasses.asdict(model)


def save(model, path) -> None:
    """Write model as JSON; one the loader would refuse is refused here, before the write."""
    check(model)
    Path(path).write_text(json.dumps(to_dict(model), indent=2) + "\n")


def load_file(path) -> Damper | SimplifiedDamper:
    path = Path(path)
    try:
        data = json.loads(read_text(path), object_pairs_hook=unique_keys)
    except FileNotFoundError:
        raise DamperError(f"{path}: no such file") from None
    except json.JSONDecodeError as e:
        raise DamperError(f"{path}: not valid JSON (line {e.lineno}: {e.msg})") from None
    except UnicodeDecodeError:
        raise DamperError(f"{path}: not a text (JSON) file") from None
    except (OSError, RecursionError) as e:
        raise DamperError(f"{path}: cannot read ({getattr(e, 'strerror', None) or type(e).__name__})") from None
    except DamperError as e:
        raise DamperError(f"{path}: {e}") from None
    try:
        return from_dict(data)
    except DamperError as e:
        raise DamperError(f"{path.name}: {e}") from None


def unique_keys(pairs):
    """json's object_pairs_hook: a key given twice is refused (json would keep the last)."""
    out = {}
    for k, v in pairs:
        if k in out:
            raise DamperError(f"key {k!r} given twice in one object")
        out[k] = v
    return out


def read_text(path: Path) -> str:
    """A regular file's text: a FIFO or device would block or never end."""
    if path.exists() and not path.is_file():
        raise DamperError("not a regular file (a FIFO, socket or device is not read)")
    return path.read_text(encoding="utf-8")


def preset_names() -> list[str]:
    return sorted(p.stem for p in PRESET_DIR.glob("*.json"))


def load(name_or_path) -> Damper | SimplifiedDamper:
    """A preset by name (koni, mechformance, fox-light, fox-heavy, simplified-I, ...) or a
    path to a JSON file; a model already loaded is returned as it is."""
    if isinstance(name_or_path, (Damper, SimplifiedDamper)):
        return name_or_path
    s = str(name_or_path)
    if s.endswith(".json") or "/" in s:
        return load_file(s)
    p = PRESET_DIR / f"{s}.json"
    if not p.exists():
        raise DamperError(f"unknown damper preset {s!r} (known: {', '.join(preset_names())})")
    return load_file(p)


# --- physical checks ----------------------------------------------------------------------

def check_ranges(obj, where="") -> None:
    """Every field declared with q() within its range, through nested dataclasses."""
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        path = f"{where}.{f.name}" if where else f.name
        if dataclasses.is_dataclass(value):
            check_ranges(value, path)
        elif "range" in f.metadata:
            lo, hi = f.metadata["range"]
            unit = "" if f.metadata["unit"] == "-" else f" {f.metadata['unit']}"
            for i, v in enumerate(value if isinstance(value, list) else [value]):
                if v is not None and not lo <= v <= hi:
                    at = f"{path}[{i}]" if isinstance(value, list) else path
                    raise DamperError(f"{at}: {v:g}{unit} is outside {lo:g}..{hi:g}{unit}")


def _positive(value, path):
    if not value > 0:
        raise DamperError(f"{path}: must be positive, got {value}")


def _check_direction(d: Direction, sign: float, path: str):
    b = d.low
    if abs(b.C_orrpw) + b.C_linpw < LOW_BRANCH_MIN:  # a closed valve: the flow through it is infinite
        raise DamperError(f"{path}.low: needs C_orrpw or C_linpw (together at least {LOW_BRANCH_MIN:g} N at 1 m/s, "
                          f"got {abs(b.C_orrpw) + b.C_linpw:g})")
    if b.C_orrpw * sign < 0 or b.C_linpw < 0 or b.C_ipw * sign < 0:
        raise DamperError(f"{path}.low: coefficient signs do not give a "
                          f"{'positive' if sign > 0 else 'negative'} force")
    for tag in ("mid", "high"):
        line = getattr(d, tag)
        if line is not None:
            if line.C_ilinw * sign < 0:
                raise DamperError(f"{path}.{tag}.C_ilinw: wrong sign for this direction")
    if d.high is not None:
        if d.mid is None:
            raise DamperError(f"{path}.high: needs a mid-speed valve to cross over from")
        if d.high.C_linw == d.mid.C_linw:
            raise DamperError(f"{path}.high: parallel to mid, no crossover")
        vx = (d.high.C_ilinw - d.mid.C_ilinw) / (d.mid.C_linw - d.high.C_linw)
        if vx * sign <= 0:
            raise DamperError(f"{path}.high: crosses mid on the wrong side of zero velocity")


def gas_volume_min(d: Damper, T: float) -> float:
    """Smallest gas volume over the stroke at temperature T [m^3] (eq 4.4 at full stroke)."""
    g = d.gas_spring
    return g.V0 - d.geometry.stroke * d.geometry.A_r - ((T - T_STD) * g.K_voil + g.K_voint)


def check_temperature(d: Damper, T: float) -> None:
    if not T > 0:
        raise DamperError(f"temperature {T} K is not physical")
    if gas_volume_min(d, T) <= 0.05 * d.gas_spring.V0:
        raise DamperError(f"gas_spring: gas volume exhausted at full stroke and {T - 273.15:.0f} C (V0 "
                          f"{d.gas_spring.V0:g} m^3 less stroke x A_r and the oil's expansion by K_voil, K_voint "
                          f"leaves {gas_volume_min(d, T):.3g} m^3, under 5 % of V0)")


def check(model) -> None:
    """The declared ranges, then the relations between fields; DamperError naming the first
    field that is not physical."""
    check_ranges(model)
    if isinstance(model, SimplifiedDamper):
        for tag in ("compression", "rebound"):
            d = getattr(model, tag)
            _positive(d.c_low, f"{tag}.c_low")
            _positive(d.c_mid, f"{tag}.c_mid")
            if d.v_transition is not None and d.v_transition * (1 if tag == "compression" else -1) <= 0:
                raise DamperError(f"{tag}.v_transition: wrong sign for this direction")
        return
    g, geo = model.gas_spring, model.geometry
    for name in ("A_p", "A_r", "stroke", "V_total", "V20"):
        _positive(getattr(geo, name), f"geometry.{name}")
    if geo.A_r >= geo.A_p:
        raise DamperError("geometry.A_r: rod area must be smaller than piston area A_p")
    if geo.V20 >= geo.V_total:
        raise DamperError(f"geometry.V20: {geo.V20:g} m^3 is not below V_total {geo.V_total:g} m^3 "
                          f"(chamber 2 is part of the oil volume)")
    # chamber 1 gives up A_p per metre of stroke, less the rod's share in a monotube (eqs 3.33, 3.46)
    swept = geo.stroke * (geo.A_p if model.layout == "remote_reservoir" else geo.A_p - geo.A_r)
    if geo.V_total - geo.V20 - swept <= 0:
        raise DamperError(f"geometry.V_total: chamber 1 ({geo.V_total - geo.V20:g} m^3 at full extension) "
                          f"goes negative over the {geo.stroke:g} m stroke ({swept:g} m^3 swept)")
    if model.x_mid is not None and not 0 < model.x_mid < geo.stroke:
        raise DamperError(f"x_mid: {model.x_mid:g} m is outside the stroke 0..{geo.stroke:g} m")
    for name in ("P0", "V0", "T0"):
        _positive(getattr(g, name), f"gas_spring.{name}")
    if not 1.0 <= g.gamma <= 1.67:
        raise DamperError(f"gas_spring.gamma: must lie between 1 (isothermal) and 1.67, got {g.gamma}")
    if g.V0 >= GAS_TO_OIL_MAX * geo.V_total:
        raise DamperError(f"gas_spring.V0: {g.V0:g} m^3 of gas is more than {GAS_TO_OIL_MAX:g} x the oil volume "
                          f"V_total {geo.V_total:g} m^3: larger than the damper")
    if g.V0 - geo.stroke * geo.A_r <= 0.05 * g.V0:
        raise DamperError("gas_spring.V0: gas volume exhausted by the stroke (stroke x A_r >= V0)")
    # the gas volume is linear in T (eq 4.4): positive at both ends of the range keeps the
    # gas pressure positive and finite over the whole stroke at every rated temperature
    for T in (T_MIN_RATED, T_MAX_RATED, model.temperature.T_ref, g.T0):
        check_temperature(model, T)
    f = model.friction
    if len(f.x_table) != len(f.F_table) or not f.x_table:
        raise DamperError("friction.F_table: must have one value per x_table entry")
    if any(b - a < X_TABLE_STEP for a, b in zip(f.x_table, f.x_table[1:])):  # eq 3.1 extrapolates the end slopes
        raise DamperError(f"friction.x_table: must increase by at least {1e6 * X_TABLE_STEP:g} um an entry")
    if any(F < 0 for F in f.F_table):
        raise DamperError("friction.F_table: friction magnitudes must be >= 0")
    if f.x_stick < 0:
        raise DamperError("friction.x_stick: must be >= 0 (0 selects eq 3.3)")
    v = model.valves
    if (model.layout == "remote_reservoir") != (v.head is not None):
        raise DamperError("valves.head: required for remote_reservoir, not allowed for monotube")
    for pname in ("piston", "head"):
        p = getattr(v, pname)
        if p is not None:
            _check_direction(p.compression, 1.0, f"valves.{pname}.compression")
            _check_direction(p.rebound, -1.0, f"valves.{pname}.rebound")
    c = model.compressibility
    if not 0.0 <= c.air_fraction < 0.2:
        raise DamperError(f"compressibility.air_fraction: {c.air_fraction} is not in [0, 0.2)")
    if c.beta_inv is not None:
        _positive(c.beta_inv, "compressibility.beta_inv")
    elif c.air_fraction:
        raise DamperError("compressibility.air_fraction: needs the oil's constant modulus beta_inv")
    else:
        for name in ("C_ibeta", "C_sbeta", "beta_min_inv"):
            if getattr(c, name) is None:
                raise DamperError(f"compressibility.{name}: missing (or give beta_inv)")
        _positive(c.C_ibeta, "compressibility.C_ibeta")
        # eq 3.32's slope: zero would be a constant modulus (give beta_inv), never capped
        _positive(c.C_sbeta, "compressibility.C_sbeta")
        _positive(c.beta_min_inv, "compressibility.beta_min_inv")
    _positive(model.temperature.T_ref, "temperature.T_ref")
