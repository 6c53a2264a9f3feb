"""GrainLearning's calibration (analysis/soil/bayes.py) on a made-up smooth bench model: it recovers the made-up
parameters, and it refuses a hole metric as a soil's target."""
import pytest

import numpy as np

from analysis.soil.bayes import calibrate, first_samples

TRUE = {"bond_kpa": 40.0, "friction_deg": 30.0, "new_contact": 0.4}
BOUNDS = {"bond_kpa": (10, 100), "friction_deg": (15, 45), "new_contact": (0, 1)}


def bench(p):
    """Cone index, c and φ of a shear box, an angle of repose: smooth in the three parameters, each response
    leaning on a different mix of them."""
    return {"cone_kpa": 8 * p["bond_kpa"] + 3 * p["friction_deg"] + 20 * p["new_contact"],
            "c_kpa": 0.6 * p["bond_kpa"] + 10 * p["new_contact"],
            "phi_deg": 0.8 * p["friction_deg"] + 5 * p["new_contact"],
            "repose_deg": 0.5 * p["friction_deg"] + 40 * p["new_contact"]}


def test_grainlearning_recovers_made_up_parameters_from_a_made_up_smooth_response():
    r = calibrate(bench, {k: (0.95 * v, 1.05 * v) for k, v in bench(TRUE).items()}, BOUNDS, samples=30, iterations=3)
    for name, value in TRUE.items():
        assert r["mean"][name] == pytest.approx(value, rel=0.08), (name, r["mean"])
        assert 0 < r["cv"][name] < 0.3
    assert len(r["samples"]) == len(r["weights"])


def test_the_first_samples_fill_the_prior_without_tying_parameters_together():
    """Twelve samples in five parameters (a bench filter's first iteration): every parameter spans its range in
    twelve strata, no two move together (GrainLearning's default Halton sequence ties the fourth and fifth), and
    the same seed draws the same samples, so a stopped filter resumes on its own evaluations."""
    bounds = {k: (0.0, 1.0 + i) for i, k in enumerate("abcde")}
    u = first_samples(bounds, 12, seed=0)
    for j, (lo, hi) in enumerate(bounds.values()):
        strata = np.floor(12 * (u[:, j] - lo) / (hi - lo)).astype(int)
        assert sorted(strata) == list(range(12))
    corr = np.corrcoef(u.T) - np.eye(5)
    assert np.abs(corr).max() < 0.25
    assert np.array_equal(u, first_samples(bounds, 12, seed=0))
    result = calibrate(lambda p: {"x": p["a"], "y": p["b"]}, {"x": (0.4, 0.6), "y": (0.9, 1.1)}, bounds,
                       samples=12, iterations=1)
    assert np.allclose(result["samples"], u)          # the filter's first iteration is these samples


def test_a_hole_metric_is_never_a_soils_target():
    with pytest.raises(ValueError, match="h1 are hole metrics"):
        calibrate(bench, {"cone_kpa": (400.0, 500.0), "h1": (12.0, 15.0)}, BOUNDS)


def test_each_miss_weighs_by_its_targets_width_not_its_size():
    """Two responses of one parameter x ask for x = 6 (a wide range, 0-12) and x = 10 (a narrow one, 9-11): the
    narrow target holds the posterior (weighed by their values instead, x would settle near 7)."""
    def model(p):
        return {"wide": p["x"], "narrow": p["x"], "other": p["y"]}
    r = calibrate(model, {"wide": (0.0, 12.0), "narrow": (9.0, 11.0), "other": (4.0, 6.0)},
                  {"x": (0.0, 20.0), "y": (0.0, 10.0)}, samples=30, iterations=3)
    assert 9.0 < r["mean"]["x"] < 11.0, r["mean"]


def test_a_target_is_a_range():
    with pytest.raises(ValueError, match="each a range"):
        calibrate(bench, {"cone_kpa": (500.0, 400.0), "c_kpa": (20.0, 35.0)}, BOUNDS)


def noisy_bench(p):
    """Three responses of two parameters, each run reading off by its packing's chaos (SD 1, a sixth of each
    target's range): the noise is the same each time the same set runs, as a run's packing is."""
    import hashlib

    import numpy as np
    rng = np.random.default_rng(int(hashlib.sha1(repr(sorted(p.items())).encode()).hexdigest()[:8], 16))
    return {"a": p["x"] + p["y"] + rng.normal(0, 1.0), "b": p["x"] - p["y"] + rng.normal(0, 1.0),
            "c": p["x"] + rng.normal(0, 1.0)}


def test_the_packing_scatter_floors_the_likelihood_so_no_lucky_run_takes_the_posterior():
    """With the runs' scatter as its floor the filter's spread never falls below it, and the last posterior keeps
    more effective samples than the search's target alone would (9 of 20 on average over four resamplings; without
    the floor 6, the target's 30 %)."""
    import numpy as np

    from analysis.soil.bayes import sigma_floor
    targets, scatter = {"a": (7.0, 13.0), "b": (-3.0, 3.0), "c": (2.0, 8.0)}, {"a": 1.0, "b": 1.0, "c": 1.0}
    floor = sigma_floor(targets, scatter)
    sizes = []
    for seed in range(4):
        r = calibrate(noisy_bench, targets, {"x": (0, 10), "y": (0, 10)}, samples=20, iterations=3, seed=seed,
                      scatter=scatter)
        assert min(r["sigma"]) >= floor * (1 - 1e-9), (r["sigma"], floor)
        sizes.append(1 / np.sum(np.asarray(r["weights"]) ** 2))
    assert np.mean(sizes) >= 6.5, sizes


def test_the_scatter_names_every_target():
    with pytest.raises(ValueError, match="scatter of b"):
        calibrate(noisy_bench, {"a": (7.0, 13.0), "b": (-3.0, 3.0)}, {"x": (0, 10), "y": (0, 10)},
                  scatter={"a": 1.0})


LOAM_FIRST = [  # loam's own-planes filter, first iteration on packing 1: c kPa, φ °, slope °, cone kPa (rounded)
    (20.4, 22.2, 33.4, 453.4), (13.7, 24.4, 33.5, 384.7), (20.2, 20.0, 34.5, 345.3), (16.7, 25.1, 34.3, 595.1),
    (18.2, 24.4, 35.2, 511.6), (14.2, 24.1, 36.0, 354.4), (16.3, 24.5, 34.0, 483.4), (18.7, 24.9, 34.2, 513.2),
    (17.6, 24.3, 35.6, 500.2), (12.4, 27.3, 37.4, 477.7), (13.1, 25.2, 31.0, 352.0), (15.4, 23.7, 35.5, 348.9)]


def test_where_the_floor_binds_the_spread_sits_on_it_and_the_sets_inside_take_the_weight():
    """Loam's first iteration keeps 42 % of its samples' weight at the packing scatter's floor, so the spread belongs
    on the floor. GrainLearning's own search over σ (to 1e6, tolerance 0.01 in σ) ends at twice the floor on these
    rounded responses, its five sets inside all four targets then holding 80 % of the weight, and on the unrounded
    ones on the plateau at σ = 6.4e5, every weight equal; searched over log σ it ends on the floor, 93 %."""
    from analysis.soil.bayes import sigma_floor
    names = ("c_kpa", "phi_deg", "collapse_deg", "cone_kpa")
    targets = {"c_kpa": (10.0, 25.0), "phi_deg": (24.0, 32.0), "collapse_deg": (30.0, 38.0), "cone_kpa": (391.0, 529.0)}
    scatter = {"c_kpa": 5.1, "phi_deg": 1.8, "collapse_deg": 1.6, "cone_kpa": 42.0}
    bounds = {"bond": (3.0e4, 6.5e4), "friction": (8.0, 13.0), "alpha": (0.2, 0.8), "eta_roll": (0.2, 0.6),
              "damping": (0.1, 0.2), "stretch": (0.75, 1.0), "young": (7.0e6, 1.2e7)}
    r = calibrate(lambda rows: [dict(zip(names, v)) for v in LOAM_FIRST], targets, bounds, samples=12, iterations=1,
                  batch=True, scatter=scatter)
    assert r["sigma"][0] < 1.1 * sigma_floor(targets, scatter), r["sigma"]     # the search's tolerance
    inside = [all(lo <= x <= hi for x, (lo, hi) in zip(v, targets.values())) for v in LOAM_FIRST]
    assert sum(inside) == 5
    assert np.asarray(r["weights"])[inside].sum() > 0.85, r["weights"]
