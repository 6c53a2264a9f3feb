"""The direct shear box's Mohr-Coulomb fit (scripts/shear.py runs the box; no YADE here).

τ_peak = c + σn·tan φ, least squares over the normal stresses, with the 95 % intervals of c and φ (Student t
on n - 2 degrees of freedom; none from two points).
"""
from __future__ import annotations

import math

import numpy as np


def mohr_coulomb(stress_kpa, tau_kpa) -> dict:
    """c (kPa) and φ (degrees) with their 95 % intervals from peak shear stresses at normal stresses.

    >>> r = mohr_coulomb([50, 100, 200], [30.0, 45.0, 75.0])
    >>> round(r["c_kpa"], 2), round(r["phi_deg"], 2)
    (15.0, 16.7)
    """
    from scipy.stats import linregress, t
    s, tau = np.asarray(stress_kpa, float), np.asarray(tau_kpa, float)
    fit = linregress(s, tau)
    n = len(s)
    half_slope = t.ppf(0.975, n - 2) * fit.stderr if n > 2 else math.nan
    half_c = t.ppf(0.975, n - 2) * fit.intercept_stderr if n > 2 else math.nan
    slope = float(fit.slope)
    return {"c_kpa": float(fit.intercept), "c_lo": float(fit.intercept - half_c), "c_hi": float(fit.intercept + half_c),
            "phi_deg": math.degrees(math.atan(slope)),
            "phi_lo": math.degrees(math.atan(slope - half_slope)), "phi_hi": math.degrees(math.atan(slope + half_slope)),
            "r2": float(fit.rvalue ** 2), "points": n}
