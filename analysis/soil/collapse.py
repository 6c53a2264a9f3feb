"""The collapse test's measurement (scripts/collapse.py runs the test; no YADE here): the slope a slumped column
of disturbed soil stands at, from its surface's height profile."""
from __future__ import annotations

import math

SLOPE_BAND = (0.2, 0.8)        # the part of the final height the slope is fitted over


def slope_angle(x, top, band=SLOPE_BAND) -> dict:
    """The surface's slope from its height profile (`x` bin centres, `top` their heights, m): a least-squares line
    through the bins whose height lies inside `band` of the highest, downhill from the crest; a face steeper than
    one bin reads as 90°.

    >>> import numpy as np
    >>> x = np.arange(0, 0.3, 0.01); h = np.clip(0.1 - (x - 0.05) * np.tan(np.radians(35)), 0, 0.1)
    >>> round(slope_angle(x, h)["angle_deg"], 1)
    35.0
    """
    import numpy as np
    x, top = np.asarray(x, float), np.asarray(top, float)
    crest = int(np.argmax(top))
    height = float(top[crest])
    x, top = x[crest:], top[crest:]
    inside = (top >= band[0] * height) & (top <= band[1] * height)
    if inside.sum() < 2:
        return {"angle_deg": 90.0, "height_m": height, "bins": int(inside.sum())}
    slope = np.polyfit(x[inside], top[inside], 1)[0]
    return {"angle_deg": float(math.degrees(math.atan(max(0.0, -slope)))), "height_m": height, "bins": int(inside.sum())}
