"""The collapse test's measurement (scripts/collapse.py runs the test; no YADE here): the slope a slumped column
of disturbed soil stands at, from its surface's height profile."""
from __future__ import annotations

import math

FLOORS = ("plane", "grains")   # the column's floor (scripts/collapse.py --floor): its own friction, or fixed grains
SLOPE_BAND = (0.2, 0.8)        # the slope runs between where the surface falls below these shares of its crest


def slope_angle(x, top, band=SLOPE_BAND) -> dict:
    """The surface's slope from its height profile (`x` bin centres, `top` their heights, m): going downhill from the
    crest (the highest bin), where the surface first falls below band[1] and below band[0] of the crest's height,
    each crossing placed by linear interpolation between the two bins it lies between (so the reading is not
    stepped by the bin width); the angle is that drop over the distance between the two crossings (a face left
    standing reads near 90°, and a grain or clump lying loose beyond the toe does not count).

    >>> import numpy as np
    >>> x = np.arange(0, 0.3, 0.012); h = np.clip(0.1 - (x - 0.05) * np.tan(np.radians(35)), 0, 0.1)
    >>> round(slope_angle(x, h)["angle_deg"], 1)
    35.0
    """
    import numpy as np
    x, top = np.asarray(x, float), np.asarray(top, float)
    crest = int(np.argmax(top))
    height = float(top[crest])
    if not np.any(top[crest:] < band[0] * height):
        return {"angle_deg": float("nan"), "height_m": height, "run_m": float("nan")}
    crossing = {}
    for b in band:
        i = crest + int(np.argmax(top[crest:] < b * height))      # the first bin below b · crest; i - 1 is at or above
        share = (top[i - 1] - b * height) / (top[i - 1] - top[i])
        crossing[b] = float(x[i - 1] + share * (x[i] - x[i - 1]))
    run = crossing[band[0]] - crossing[band[1]]
    return {"angle_deg": math.degrees(math.atan2((band[1] - band[0]) * height, run)), "height_m": height, "run_m": run}


def profile_angle(profile_mm) -> float:
    """The slope (°) of a collapse test's stored profile ([[x mm, top mm], ...], scripts/collapse.py)."""
    import numpy as np
    p = np.asarray(profile_mm, float)
    return slope_angle(p[:, 0] / 1000, p[:, 1] / 1000)["angle_deg"]
