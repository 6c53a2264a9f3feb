"""Kinematics of the duck-beak planting mechanism (seed 000, eqs 1-16)."""
import math

import numpy as np
import pytest

from analysis.pepper import check_dead_point, closure_residual, dead_point_margin, load_linkage, motion, solve, trajectory_metrics

OMEGA = 2 * math.pi                                   # 60 plants/min


@pytest.mark.parametrize("column", ["initial", "designed"])
def test_closure_equations_hold_along_the_cycle(column):
    link = load_linkage(column)
    s = solve(link, np.linspace(0, 2 * np.pi, 3601))
    assert closure_residual(link, s).max() < 1e-9
    assert np.allclose(np.abs(s["D"] - s["B"]), link.L2) and np.allclose(np.abs(s["M"] - s["D"]), link.L8)
    assert np.allclose(np.abs(s["F"] - s["G"]), link.L6) and np.allclose(np.abs(s["D"] - s["E"]), link.L4)


@pytest.mark.parametrize("column", ["initial", "designed"])
def test_velocity_and_acceleration_match_finite_differences(column):
    link = load_linkage(column)
    th = np.linspace(0.1, 2 * np.pi - 0.1, 37)
    h = 1e-4                                          # rad of crank; dt = h / ω
    _, dP, ddP = motion(link, th, OMEGA)
    P = lambda t: solve(link, t)["P"]                 # noqa: E731
    dt = h / OMEGA
    fd_v = (P(th + h) - P(th - h)) / (2 * dt)
    fd_a = (P(th + h) - 2 * P(th) + P(th - h)) / dt ** 2
    assert np.max(np.abs(dP - fd_v)) < 1e-5 * np.max(np.abs(dP))
    assert np.max(np.abs(ddP - fd_a)) < 1e-3 * np.max(np.abs(ddP))


def test_the_other_branch_of_eq13_is_another_assembly():
    a, b = load_linkage("designed"), load_linkage("designed", branch=-1)
    th = np.linspace(0, 2 * np.pi, 361)
    sa, sb = solve(a, th), solve(b, th)
    assert closure_residual(b, sb).max() < 1e-9
    assert np.max(np.abs(sa["theta4"] - sb["theta4"])) > 0.1


def test_dead_point_constraint_is_enforced():
    link = load_linkage("designed")
    s = solve(link, np.linspace(0, 2 * np.pi, 3601))
    margin = dead_point_margin(link, s)
    assert margin >= -1e-9                            # B, D, E always close a triangle
    angle = np.angle((s["B"] - s["D"]) / (s["E"] - s["D"]))
    closest = np.argmin(np.abs(np.sin(angle)))        # the margin is smallest where BD and DE line up
    assert margin < np.abs(np.abs(s["E"] - s["B"]) - abs(link.L2 - link.L4)).max()
    assert abs(np.sin(angle[closest])) < 0.2
    assert check_dead_point(link, s, tol=margin / 2) == margin
    with pytest.raises(ValueError, match="dead point"):
        check_dead_point(link, s, tol=margin + 1.0)


def test_an_unassemblable_linkage_is_a_clear_error():
    with pytest.raises(ValueError, match="cannot be assembled"):
        solve(load_linkage("designed", L6=100.0), np.linspace(0, 2 * np.pi, 73))
    with pytest.raises(ValueError, match="does not reach past the guide"):
        solve(load_linkage("designed", L2=50.0), np.linspace(0, 2 * np.pi, 73))


def test_moving_trajectory_metrics_are_those_of_a_planting_loop():
    m = trajectory_metrics(load_linkage("designed"), 300.0, OMEGA)
    assert m["crossed"] and 0 < m["depth"] < m["height"] and m["spread"] >= 0


def test_goal_attainment_improves_every_goal_from_the_initial_values():
    from analysis.pepper_design import design, goal_values, load_goals, margins, ranges, values
    goals, bounds = load_goals(), ranges()
    start = load_linkage("initial")
    F0 = goal_values(start, goals, 3601)
    d = design(start, goals, bounds, starts=2)
    miss0, miss = np.abs(F0 - goals.target), np.abs(d.F - goals.target)
    assert np.all(miss < miss0), (F0, d.F)
    assert d.gamma == pytest.approx(max(miss / goals.weight))
    x = values(d.link)
    assert np.all(x >= bounds[:, 0] - 1e-9) and np.all(x <= bounds[:, 1] + 1e-9)     # inside Table 2's ranges
    dead, assembly = margins(d.link, 3601)
    assert dead >= goals.dead_point_margin - 0.05 and assembly >= goals.assembly_margin - 0.05


def test_bad_goals_are_a_clear_error(tmp_path):
    from analysis.config import ConfigError
    from analysis.pepper_design import load_goals
    text = open("configs/pepper.toml").read().replace("weight = [1.0, 1.0, 1.0]", "weight = [1.0, 0.0, 1.0]")
    (tmp_path / "p.toml").write_text(text)
    with pytest.raises(ConfigError, match="goals.weight"):
        load_goals(tmp_path / "p.toml")


def test_frame_inference_recovers_a_known_frame(monkeypatch):
    """The frame fit (analysis/pepper_frame.py) finds a frame again from the quantities it produces: stated
    results made from a known frame (15 mm or more from a toggle in both columns) are met again from a start
    3 % off, each to < 0.5 weighted units (0.5 mm, 0.01 m/s, 0.015 s: the top and bottom are sampled every
    0.5° of crank), and the frame comes back within 1 %."""
    from scipy.optimize import least_squares
    from analysis import pepper_frame as pf
    x_true = np.array([191.625, 1.534, 98.126, 1.231, -0.986, 156.615])     # L3, θ3, L14, α, θ5, L7
    made = {c: {k: v for k, v in pf.observe(lk).items() if k in pf.WEIGHT}
            for c, lk in pf.columns(x_true, 1, "relative").items()}
    monkeypatch.setattr(pf, "STATED", made)
    assert np.max(np.abs(pf.residuals(x_true, 1, "relative"))) < 1e-9
    start = x_true * 1.03
    assert np.sqrt(np.mean(pf.residuals(start, 1, "relative") ** 2)) > 1.0
    sol = least_squares(pf.residuals, start, args=(1, "relative"), x_scale=pf.X_SCALE[:6])
    assert np.max(np.abs(sol.fun)) < 0.5
    assert sol.x == pytest.approx(x_true, rel=0.01)
