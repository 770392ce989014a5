"""The linear frictionless quarter car and its closed-form transmissibility (test helper)."""
import numpy as np

from models import quarter_car as qcm


def linear_car():
    return qcm.QuarterCar("linear", m_s=252.5, m_u=45.4, k_s=70e3, k_t=350e3, c_tire=0.0, F_c1=0.0, F_c3=0.0)


def transmissibility(qc, c, f):
    """(|Y1/Yin|, |Y2/Yin|) of the linear 2-DOF model with a viscous damper c [N s/m] at f [Hz]."""
    w = 2 * np.pi * f
    M = np.diag([qc.m_s, qc.m_u])
    K = np.array([[qc.k_s, -qc.k_s], [-qc.k_s, qc.k_s + qc.k_t]])
    C = np.array([[c, -c], [-c, c]])
    Y = np.linalg.solve(-w**2 * M + 1j * w * C + K, np.array([0.0, qc.k_t]))
    return abs(Y[0]), abs(Y[1])
