"""Quarter-car models (thesis chapter 5): parameters as data, static equilibrium, and the
linearised natural frequencies.

Coordinates: y1 sprung, y2 unsprung, y_in road input, positive up [m]; z1 = y1 - y2
(suspension), z2 = y2 - y_in (tire). Masses kg, stiffness N/m, damping N s/m, forces N.

Two parameter sets ship in presets/quarter-car/: `simulator` (the laboratory quarter-car
simulator, eqs 5.1-5.11, Table 2.2, friction of 5.3) and `race-car` (the analysis model,
eqs 5.12-5.14). The time-domain model (friction, lift-off, limit stops) builds on these.
"""
from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from models.damper import DamperError, build, read_text, unique_keys

G = 9.81  # m/s^2
PRESET_DIR = Path(__file__).parent.parent / "presets" / "quarter-car"


@dataclass
class QuarterCar:
    name: str
    m_s: float  # sprung mass [kg]
    m_u: float  # unsprung mass [kg]
    k_s: float  # suspension spring K_s1 [N/m]
    k_t: float  # tire spring K_s2 [N/m]
    c_tire: float  # tire viscous damping C_tire [N s/m] (eq 5.14; 0 on the simulator)
    F_c1: float  # Coulomb friction sprung-unsprung [N] (eq 5.11)
    F_c3: float  # Coulomb friction sprung-input [N] (eq 5.11; 0 on a car)
    description: str = ""


def load(name_or_path) -> QuarterCar:
    s = str(name_or_path)
    path = Path(s) if s.endswith(".json") else PRESET_DIR / f"{s}.json"
    if not path.exists():
        known = ", ".join(sorted(p.stem for p in PRESET_DIR.glob("*.json")))
        raise DamperError(f"unknown quarter-car {s!r} (known: {known})")
    try:
        qc = build(QuarterCar, json.loads(read_text(path), object_pairs_hook=unique_keys), "")
        check(qc)
    except json.JSONDecodeError as e:
        raise DamperError(f"{path.name}: not valid JSON (line {e.lineno}: {e.msg})") from None
    except UnicodeDecodeError:
        raise DamperError(f"{path.name}: not a text (JSON) file") from None
    except (OSError, RecursionError) as e:
        raise DamperError(f"{path.name}: cannot read ({getattr(e, 'strerror', None) or type(e).__name__})") from None
    except DamperError as e:
        raise DamperError(f"{path.name}: {e}") from None
    return qc


def check(qc: QuarterCar) -> None:
    for name in ("m_s", "m_u", "k_s", "k_t"):
        if not getattr(qc, name) > 0:
            raise DamperError(f"{name}: must be positive, got {getattr(qc, name)}")
    for name in ("c_tire", "F_c1", "F_c3"):
        if getattr(qc, name) < 0:
            raise DamperError(f"{name}: must not be negative, got {getattr(qc, name)}")


def to_dict(qc: QuarterCar) -> dict:
    return asdict(qc)


def static_deflections(qc: QuarterCar, F_gas=0.0):
    """Suspension and tire static deflections [m], eqs 5.1-5.2: the damper's gas force
    F_gas [N] carries part of the sprung weight."""
    z_pre1 = (qc.m_s * G - F_gas) / qc.k_s  # eq 5.1
    z_pre2 = (qc.m_s + qc.m_u) * G / qc.k_t  # eq 5.2
    return z_pre1, z_pre2


def tire_damping_for_ratio(qc: QuarterCar, zeta=0.05):
    """C_tire [N s/m] giving the unsprung (wheel-hop) mode a damping ratio zeta with the
    sprung mass held: c = 2 zeta sqrt((k_s + k_t) m_u) (our reading of 'tire damping for
    5 % unsprung-mode damping', 5.2.2)."""
    return 2.0 * zeta * np.sqrt((qc.k_s + qc.k_t) * qc.m_u)


def natural_frequencies(qc: QuarterCar, k_damper=0.0):
    """Undamped natural frequencies [Hz] (bounce, wheel hop) of the linearised 2-DOF
    model (Table 5.3); k_damper adds a linear stiffness in parallel with the spring
    (a gas spring's rate, say)."""
    k = qc.k_s + k_damper
    M = np.diag([qc.m_s, qc.m_u])
    K = np.array([[k, -k], [-k, k + qc.k_t]])
    w2 = np.linalg.eigvals(np.linalg.solve(M, K)).real
    return tuple(np.sort(np.sqrt(w2)) / (2 * np.pi))


def tire_mode_frequency(qc: QuarterCar):
    """Single-DOF tire mode [Hz]: both masses on the tire spring (6.2.1)."""
    return float(np.sqrt(qc.k_t / (qc.m_s + qc.m_u)) / (2 * np.pi))
