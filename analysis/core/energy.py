"""The tools' energy balance and its guard (no YADE): what the disk scene's work on the soil went into, and the
stop when an integration makes or eats energy no force booked (scripts/disk_parts.py reads the terms from YADE).
"""
from __future__ import annotations


def energy_balance(start: dict, end: dict) -> dict:
    """The tools' work on the soil beside what it went into, between two `energy_now` readings (J):
    work = Δkinetic + Δelastic + Δpotential + dissipated − window + residual (window: the awake window's jumps).
    The residual is what no term books: the elastic energy of cohesive bonds at the moment they break (YADE's
    CohFrictPhys law does not book it) and the time integration's error."""
    delta = {k: end[k] - start.get(k, 0.0) for k in end}
    stored = {f"d_{k}": delta.pop(k) for k in ("kinetic", "elastic", "potential")}
    work = delta.pop("work_tool")
    # the awake window: the stored energy's jumps at its moves (bonds between sleepers dropped, new ones made,
    # the kinetic energy of the grains put to sleep); no force did work on them
    window = delta.pop("window", None)
    residual = work - sum(stored.values()) - sum(delta.values()) + (window or 0.0)   # `delta`: the booked dissipation
    return {"work_tool": work, **stored, **({"window": window} if window is not None else {}),
            **{f"dissipated_{k}": v for k, v in delta.items()},
            "residual": residual, "residual_fraction": residual / work if work else float("nan")}


TOOL_RESIDUAL_LIMIT = 0.5             # the residual may not pass this share of the tools' work (or of the scale)


def tool_guard(balance: dict, scale: float):
    """The guard on the tools, as `guard` is on the grains: the energy balance since the start (energy_balance)
    may leave unexplained at most TOOL_RESIDUAL_LIMIT of the tools' work, or of `scale` (J, the whole bed at the
    tool's top speed) while the work is still smaller. A finished strip leaves 2-3 %; an unstable sleeve or
    disk integration makes or eats energy no force booked, and the run stops naming it, before any result.

    >>> tool_guard({"work_tool": 400.0, "residual": 10.0}, 10.0)
    >>> tool_guard({"work_tool": -577906.0, "residual": -618000.0}, 10.0)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    RuntimeError: the tools' energy balance broke: work -5.78e+05 J, residual -6.18e+05 J (more than 50 % ...
    """
    work, residual = balance["work_tool"], balance["residual"]
    if not abs(residual) <= TOOL_RESIDUAL_LIMIT * max(abs(work), scale):
        raise RuntimeError(f"the tools' energy balance broke: work {work:.3g} J, residual {residual:.3g} J (more than "
                           f"{100 * TOOL_RESIDUAL_LIMIT:.0f} % of the work or of {scale:.3g} J): the tool integration is "
                           "unstable (sleeve mass, stiffness or step)")
