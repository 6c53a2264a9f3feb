"""The direct shear box's Mohr-Coulomb fit (scripts/shear.py runs the box; no YADE here).

τ_peak = c + σn·tan φ, least squares over the normal stresses, with the 95 % intervals of c and φ (Student t
on n - 2 degrees of freedom; none from two points).
"""
from __future__ import annotations

import math

import numpy as np


def sheared_stress(test: dict) -> float:
    """The normal stress on the sheared area at a test's peak (kPa): the load over what is left of the plane
    once the halves have shifted, σn·L / (L − shift at the peak)."""
    length_mm = 1000 * test["size_m"][0]
    return test["stress_kpa"] * length_mm / (length_mm - test["shift_at_peak_mm"])


def fit_tests(tests: list[dict]) -> dict:
    """The Mohr-Coulomb fit of a shear box's tests: each peak shear stress against the normal stress on the
    sheared area at that peak (both over the same area).

    >>> t = [{"size_m": [0.15], "stress_kpa": s, "shift_at_peak_mm": 30.0, "tau_peak_kpa": 20 + 0.6 * s * 1.25}
    ...      for s in (50, 100, 200)]
    >>> r = fit_tests(t)
    >>> round(r["c_kpa"], 2), round(r["phi_deg"], 2)
    (20.0, 30.96)
    """
    return mohr_coulomb([sheared_stress(t) for t in tests], [t["tau_peak_kpa"] for t in tests])


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
