"""Temperature sensitivity of the damping force (thesis 3.3.5, 4.2.4).

Oil density falls as the oil warms, so a valve passes the same flow at a lower pressure
drop. Eq 4.17 (eq 3.61 plus the thesis's regression intercept):
    f_FT = 1 / (1 + K_effoil * dT_d + C_fd),   dT_d = T - T_ref
with K_effoil in 1/K and C_fd dimensionless, one pair each for compression and rebound
(Table 4.10). The damping force at T is F_dT = F_dTref * f_FT (eq 3.62).
"""
from __future__ import annotations

import numpy as np


def oil_volume_ratio(T, T_ref, K_Toil):
    """Damping force ratio from oil expansion alone, eqs 3.58-3.60: 1/(1 + dT K_Toil)."""
    return 1.0 / (1.0 + (np.asarray(T, float) - T_ref) * K_Toil)


def damping_factor(T, T_ref, K_effoil, C_fd):
    """Normalised damping force f_FT, eq 4.17  [-]."""
    return 1.0 / (1.0 + K_effoil * (np.asarray(T, float) - T_ref) + C_fd)
