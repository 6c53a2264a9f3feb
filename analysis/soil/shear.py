"""The direct shear box's Mohr-Coulomb fit (scripts/shear.py runs the box, scripts/simple_shear.py the wall-free
cell, fitted alike; no YADE here).

τ_peak = c + σ·tan φ, least squares over the normal stresses, σ the normal stress the plane carries at the peak
(the lid's load and the weight resting on the plane, over the sheared area), with the 95 % intervals of c and φ (Student t
on n - 2 degrees of freedom; none from two points).
"""
from __future__ import annotations

import math

import numpy as np

READING = "plane load"     # the normal stress c and φ are fitted against (`sheared_stress`); a posterior records it


def plane_load(test: dict) -> float:
    """The normal load the grains carry across the shear plane over the box's whole area (kPa): the median, over the
    test's curve, of the plane's normal stress times the share of the plane still sheared, (L − shift) / L. It is the
    lid's dead load σn and what else rests on the plane, the lid's own weight and the soil above the plane: about
    2.4 kPa more than σn at r = 6 mm in the 225 mm box, at every σn.

    >>> curve = [[s, 0.0, 0.0, 0.0, 52.4 * 150 / (150 - s)] for s in (0, 10, 20, 30)]
    >>> round(plane_load({"size_m": [0.15], "curve": curve}), 2)
    52.4
    """
    length_mm = 1000 * test["size_m"][0]
    curve = np.asarray(test["curve"], float)
    return float(np.median(curve[:, 4] * (length_mm - curve[:, 0]) / length_mm))


def sheared_stress(test: dict) -> float:
    """The normal stress on the sheared area at a test's peak (kPa): the plane's load (`plane_load`) over what is left
    of the plane once the halves have shifted, P·L / (L − shift at the peak). A laboratory counts its loading cap's
    weight in the normal load the same way."""
    length_mm = 1000 * test["size_m"][0]
    return plane_load(test) * length_mm / (length_mm - test["shift_at_peak_mm"])


def peak_stress(test: dict) -> float:
    """The normal stress a test's peak was read at (kPa): a shear box's on its sheared area (`sheared_stress`), a
    simple shear cell's σzz at its peak (scripts/simple_shear.py), which has no area to lose."""
    return test["sigma_at_peak_kpa"] if "sigma_at_peak_kpa" in test else sheared_stress(test)


def fit_tests(tests: list[dict]) -> dict:
    """The Mohr-Coulomb fit of a shear box's (or simple shear cell's) tests: each peak shear stress (the frames' push
    over the sheared area) against the normal stress at that peak (`peak_stress`).

    >>> def test(s, w=2.4):
    ...     return {"size_m": [0.15], "stress_kpa": s, "shift_at_peak_mm": 30.0, "tau_peak_kpa": 20 + 0.6 * (s + w) * 1.25,
    ...             "curve": [[x, 0.0, 0.0, 0.0, (s + w) * 150 / (150 - x)] for x in (0, 15, 30)]}
    >>> r = fit_tests([test(s) for s in (50, 100, 200)])
    >>> round(r["c_kpa"], 2), round(r["phi_deg"], 2)
    (20.0, 30.96)
    >>> cell = [{"stress_kpa": s, "sigma_at_peak_kpa": s + 0.1, "tau_peak_kpa": 5 + 0.5 * (s + 0.1)} for s in (50, 100, 200)]
    >>> round(fit_tests(cell)["c_kpa"], 2)
    5.0
    """
    return mohr_coulomb([peak_stress(t) for t in tests], [t["tau_peak_kpa"] for t in tests])


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
