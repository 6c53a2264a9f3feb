"""The error budget's tools (analysis/holes/budget.py) on made-up cases: the r -> 0 limit of a power law, parts that
add up, and a screening that finds the one unknown that matters."""
import numpy as np
import pytest

from analysis.holes.budget import budget, extrapolate, morris, morris_design, power_law, within_of_limit


@pytest.mark.parametrize("order", [1.0, 1.5, 2.0])
def test_the_extrapolation_recovers_the_limit_of_a_made_up_power_law_through_its_scatter(order):
    """h1-like: 14 mm at r -> 0, rising with the grain radius, each mean off by its standard error (0.5 mm) at the
    radii the presets use; the limit lies in the interval, and the interval is not wider than the scatter allows."""
    radii = np.array([8.0, 6.0, 5.0, 4.0, 3.0])
    rng = np.random.default_rng(int(10 * order))
    means = power_law(radii, 14.0, 0.4, order) + rng.normal(0, 0.5, len(radii))
    r = extrapolate(radii, means, [0.5] * len(radii), n_boot=300)
    assert r["m0_lo"] <= 14.0 <= r["m0_hi"] and r["fitted_order"], r       # the order fitted: a wide interval
    known = extrapolate(radii, means, [0.5] * len(radii), n_boot=300, p=order, fit_order=False)
    assert known["m0_lo"] <= 14.0 <= known["m0_hi"] and known["m0_hi"] - known["m0_lo"] < 4.0, known
    assumed = extrapolate(radii[:3], power_law(radii[:3], 14.0, 0.4, 1.0), [0.01] * 3, p=1.0, n_boot=100)
    assert assumed["m0"] == pytest.approx(14.0, abs=0.05) and not assumed["fitted_order"]


def test_the_budgets_parts_add_up_on_a_made_up_case():
    b = budget(63.4, 62.1, 60.9, measurement=11.2, machine=3.0, soil=2.0, packing=1.5)
    assert b["grain_size"] + b["model"] == pytest.approx(b["miss"])
    assert b["uncertain"] == pytest.approx(np.sqrt(11.2 ** 2 + 3 ** 2 + 2 ** 2 + 1.5 ** 2))
    assert not b["resolved"] and b["dominant"] == "measurement"
    with pytest.raises(ValueError, match="unknown part"):
        budget(1.0, 0.0, 0.5, weather=1.0)


def test_a_limit_within_5_pct_is_claimed_only_with_its_whole_interval():
    limit = {"m0": 60.0, "m0_lo": 58.5, "m0_hi": 62.0}
    assert within_of_limit(60.5, limit, 62.1) and not within_of_limit(63.0, limit, 62.1)


def test_morris_screening_ranks_the_unknown_that_matters_first():
    problem, X = morris_design({"penetration": (70, 95), "spring": (0.5, 8), "preload": (0, 50)}, trajectories=20)
    ranks = morris(problem, X, 0.8 * X[:, 0] + 0.05 * X[:, 1] + 0 * X[:, 2])
    assert list(ranks) == ["penetration", "spring", "preload"] and ranks["preload"]["mu_star"] < 1e-9


def test_the_budget_table_puts_each_part_from_its_source_on_made_up_results():
    """Made-up comparison, holes of three packings, grain-size limits and machine design: the grain-size shift is the
    mean at the preset's radius minus the limit, the packing's half-width t·SD/√n of the runs' means, the machine's
    its slopes times the fit's half-intervals in quadrature, and the systematic parts add up to the miss."""
    import pandas as pd
    from analysis.holes import budget_report
    comparison = pd.DataFrame([{"soil": "clay", "metric": "h1", "field_mean": 13.5, "sim_mean": 17.0, "band": 5.0,
                                "calibration_target": False, "n_holes": 6, "n_runs": 3}])
    holes = pd.DataFrame({"soil": "clay", "run": ["a", "a", "b", "b", "c", "c"], "found": True,
                          "h1": [15.0, 17.0, 16.0, 18.0, 17.0, 19.0]})          # run means 16, 17, 18
    grain = pd.DataFrame([{"metric": "h1", "radius_mm": 6.0, "mean": 20.0, "limit": 12.0, "limit_lo": 10.0,
                           "limit_hi": 14.0}, {"metric": "h1", "radius_mm": 5.0, "mean": 18.0, "limit": 12.0,
                                               "limit_lo": 10.0, "limit_hi": 14.0}])
    design = pd.DataFrame({"run": list("wxyz"), "P": [70, 70, 90, 90], "stiffness": [1, 4, 1, 4], "found": True,
                           "L0": 80.0, "L1": 50.0, "L2": 40.0, "L2_surface": 50.0,
                           "h1": [10.0, 16.0, 20.0, 26.0]})                    # 0.5 mm/mm in P, 2 mm per N/mm in k
    fit = pd.Series({"P_lo": 76.0, "P_hi": 84.0, "stiffness_lo": 1.0, "stiffness_hi": 3.0})
    row = budget_report.table(comparison, holes, grain, 6.0, design, fit).iloc[0]
    assert row.grain_size == pytest.approx(8.0) and row.model == pytest.approx(17.0 - 8.0 - 13.5)
    assert row.grain_size + row.model == pytest.approx(row.miss)
    assert row.packing == pytest.approx(4.303 * 1.0 / np.sqrt(3), rel=1e-3)
    assert row.machine == pytest.approx(np.hypot(0.5 * 4.0, 2.0 * 1.0))
    assert row.not_measured == "soil_parameters" and row.dominant == "grain_size"
    one = budget_report.table(comparison, holes[holes.run == "a"], grain, 4.0, None, None).iloc[0]
    assert np.isnan(one.packing) and np.isnan(one.grain_size) and np.isnan(one.machine)
    assert one.not_measured == "grain_size, model, machine, soil_parameters, packing" and one.dominant == "measurement"


def test_a_metric_the_convergence_study_lacks_takes_the_strips_limit_and_says_so():
    """The openings are not in the convergence study: their grain-size part comes from the validation's strip and the
    row names it; a metric both read keeps the convergence study's; one neither reads stays not measured."""
    import pandas as pd
    from analysis.holes import budget_report
    comparison = pd.DataFrame([{"soil": "sand", "metric": m, "field_mean": 50.0, "sim_mean": 60.0, "band": 5.0,
                                "calibration_target": False, "n_holes": 8, "n_runs": 1} for m in ("L0", "h1", "L1")])
    holes = pd.DataFrame({"soil": "sand", "run": ["a"] * 2, "found": True, "L0": 60.0, "h1": 60.0, "L1": 60.0})
    convergence = pd.DataFrame([{"metric": "h1", "radius_mm": 6.0, "mean": 20.0, "limit": 12.0, "limit_lo": 10.0,
                                 "limit_hi": 14.0}])
    strip = pd.DataFrame([{"metric": m, "radius_mm": 6.0, "mean": 70.0, "limit": 61.0, "limit_lo": 40.0,
                           "limit_hi": 80.0} for m in ("L0", "h1")])
    t = budget_report.table(comparison, holes, budget_report.grain_limits(convergence, strip), 6.0, None, None)
    t = t.set_index("metric")
    assert t.loc["L0", "grain_size"] == pytest.approx(9.0) and t.loc["L0", "grain_size_source"] == "strip"
    assert (t.loc["L0", "grain_size_lo"], t.loc["L0", "grain_size_hi"]) == pytest.approx((-10.0, 30.0))
    assert t.loc["h1", "grain_size"] == pytest.approx(8.0) and t.loc["h1", "grain_size_source"] == "convergence"
    assert np.isnan(t.loc["L1", "grain_size"]) and t.loc["L1", "grain_size_source"] == ""
    assert "grain_size" in t.loc["L1", "not_measured"] and "grain_size" not in t.loc["L0", "not_measured"]


def test_the_validation_strips_at_three_grain_sizes_give_each_metrics_limit():
    """Clay's rows of the three validation presets (r = 6, 5, 4 mm), made up linear in r with small scatter: the
    limit of each metric comes back inside its interval, and a grain size is judged within 5 % only when it is."""
    import pandas as pd
    from analysis.batch.bench_reference import STRIP_METRICS, STRIP_PRESETS, grain_size, strip_means
    field = {"L0": 91.8, "L1": 49.9, "L2": 62.1, "L2_surface": 62.1, "h1": 13.5}
    limit = {"L0": 95.0, "L1": 48.0, "L2": 50.0, "L2_surface": 60.0, "h1": 8.0}
    slope = {"L0": -2.0, "L1": 1.5, "L2": -1.0, "L2_surface": 0.2, "h1": 1.5}
    radius = dict(zip(STRIP_PRESETS["bench_validation"], (6.0, 5.0, 4.0)))
    rows = [{"preset": p, "soil": s, "metric": m, "sim_mean": limit[m] + slope[m] * r, "sim_sd": 0.2, "n_holes": 16,
             "n_runs": 2, "field_mean": field[m]} for p, r in radius.items() for m in STRIP_METRICS
            for s in ("clay", "sand")]
    means = strip_means(pd.DataFrame(rows))
    assert len(means) == 3 * len(STRIP_METRICS) and set(means.radius_mm) == {4.0, 5.0, 6.0}
    t = grain_size(means, STRIP_METRICS, "n")
    for m in STRIP_METRICS:
        g = t[t.metric == m].iloc[0]
        assert g.limit_lo <= limit[m] <= g.limit_hi and g.limit == pytest.approx(limit[m], abs=0.01), g.to_dict()
    at6 = t[(t.radius_mm == 6.0)].set_index("metric")
    assert bool(at6.loc["L2_surface", "within_5pct"]) and not bool(at6.loc["h1", "within_5pct"])


def test_a_machine_folder_without_a_fit_is_refused(tmp_path, capsys):
    from analysis import cli
    assert cli.main(["budget", "--machine-dir", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "--machine-dir" in err and "machine_fit.csv" in err and "allowed" in err and "Traceback" not in err, err


def test_the_bond_interval_covers_a_made_up_bond_through_packing_scatter():
    """A made-up cone: 8 kPa of cone index per kPa of bond, 450 kPa at 50 kPa, packings scattered by 30 kPa; over
    many made-up calibrations the bond's 95 % interval holds the true 50 kPa about 95 % of the time."""
    from analysis.holes.budget import bond_interval
    rng = np.random.default_rng(3)
    cover = []
    for _ in range(400):
        bonds = np.array([40.0, 55.0, 48.0])
        cones = 450 + 8 * (bonds - 50) + rng.normal(0, 30 / np.sqrt(3), 3)
        r = bond_interval(bonds, cones, 48.0, 450 + 8 * (48 - 50) + rng.normal(0, 30, 5), 450.0)
        cover.append(r["lo"] <= 50.0 <= r["hi"])
    assert 0.88 <= np.mean(cover) <= 0.995, np.mean(cover)
    one = bond_interval([40, 50], [370, 450], 50, [450.0], 450)
    assert np.isnan(one["half_width"]) and one["centre"] == pytest.approx(50.0)


def test_the_soil_part_is_the_bond_slope_times_its_half_width_on_made_up_strips():
    """A strip with the bond 10 kPa lower whose h1 is 2 mm higher than the same packing's validation strip: the slope
    is −0.2 mm/kPa and the soil part 0.2 × the bond's half-width; the budget table takes it as soil_parameters and no
    longer names it not measured; another packing's holes do not enter."""
    import pandas as pd
    from analysis.holes import budget_report
    bonds = pd.DataFrame([{"soil": "clay", "adopted": 48.0, "half_width": 7.5}])
    holes = pd.DataFrame({"soil": "clay", "seed": [1] * 4 + [2] * 4, "run": ["a"] * 4 + ["b"] * 4, "found": True,
                          **{m: 50.0 for m in budget_report.METRICS}})
    holes["h1"] = [15.0, 16.0, 17.0, 16.0, 40.0, 41.0, 42.0, 43.0]              # packing 1: mean 16
    case = {"soil": "clay", "seed": 1, "soil.normal_cohesion": 38000.0, "found": 4, "run": "c",
            **{m: 50.0 for m in budget_report.METRICS}, **{f"{m}_sd": 1.0 for m in budget_report.METRICS}}
    case["h1"] = 18.0
    parts = budget_report.soil_slopes(pd.DataFrame([case]), holes, bonds)
    h1 = parts.set_index("metric").loc["h1"]
    assert h1.slope_mm_per_kpa == pytest.approx(-0.2) and h1.soil_part == pytest.approx(1.5)
    assert h1.soil_part_hi > h1.soil_part and parts.set_index("metric").loc["L0"].soil_part == pytest.approx(0.0)
    comparison = pd.DataFrame([{"soil": "clay", "metric": "h1", "field_mean": 13.5, "sim_mean": 16.0, "band": 5.0,
                                "calibration_target": False, "n_holes": 4, "n_runs": 1}])
    row = budget_report.table(comparison, holes[holes.seed == 1], pd.DataFrame(columns=["metric"]), 6.0, None, None,
                              parts).iloc[0]
    assert row.soil_parameters == pytest.approx(1.5) and "soil_parameters" not in row.not_measured


def test_the_bench_soils_part_is_their_posterior_strips_weighted_spread(tmp_path):
    """The bench soils' part: 1.96 × the weighted SD of the posterior study's strips (reliability weights), written
    beside the budget and taken by its table; before the posterior study has run there is none."""
    import pandas as pd
    from analysis.holes import budget_report
    study = tmp_path / "soil_posterior.csv"
    pd.DataFrame({"soil": "clay", "posterior_weight": [0.5, 0.25, 0.25], "found": 8,
                  **{m: [50.0, 50.0, 50.0] for m in budget_report.METRICS}}).assign(h1=[10.0, 12.0, 8.0], h1_sd=2.0).to_csv(
        study, index=False)
    parts = budget_report.posterior_soil_parts(tmp_path, "# made up", study)
    h1 = parts.set_index("metric").loc["h1"]
    assert h1.soil_part == pytest.approx(1.96 * np.sqrt(2 / 0.625)) and parts.set_index("metric").loc["L0"].soil_part == 0
    assert h1.strip_noise == pytest.approx(1.96 * 2 / np.sqrt(8))      # the strips' own hole scatter alone
    assert np.isnan(parts.set_index("metric").loc["L0"].strip_noise)   # no L0_sd in the table
    assert (tmp_path / "soil_posterior.csv").exists()
    comparison = pd.DataFrame([{"soil": "clay", "metric": "h1", "field_mean": 13.5, "sim_mean": 10.0, "band": 5.0,
                                "calibration_target": False, "n_holes": 8, "n_runs": 1}])
    holes = pd.DataFrame({"soil": "clay", "run": "a", "found": True, "h1": [9.0, 11.0]})
    row = budget_report.table(comparison, holes, pd.DataFrame(columns=["metric"]), 6.0, None, None, parts).iloc[0]
    assert row.soil_parameters == pytest.approx(h1.soil_part) and "soil_parameters" not in row.not_measured
    assert budget_report.posterior_soil_parts(tmp_path, "# made up", tmp_path / "none.csv") is None


def test_a_soils_part_waits_for_every_strip_of_its_posterior_samples(tmp_path, capsys):
    """Two of a soil's three posterior strips finished (weights 0.5 + 0.25 of 1): its part is not measured, and
    says so, rather than a spread over a subset the study's definition does not name; the finished soil's is."""
    import pandas as pd
    from analysis.holes import budget_report
    study = tmp_path / "soil_posterior.csv"
    pd.DataFrame({"soil": ["clay"] * 3 + ["loam"] * 2, "posterior_weight": [0.5, 0.25, 0.25, 0.5, 0.25], "found": 8,
                  **{m: [50.0, 52.0, 48.0, 50.0, 40.0] for m in budget_report.METRICS}}).to_csv(study, index=False)
    parts = budget_report.posterior_soil_parts(tmp_path, "# made up", study)
    assert set(parts.soil) == {"clay"} and (parts.samples == 3).all()
    assert "loam's soil part not measured" in capsys.readouterr().err


def test_a_budget_written_elsewhere_names_its_folder_and_leaves_the_validations_alone(tmp_path):
    """`budget --out F`: the table, its picture and the soil part's table go to F, whose stamp names --out F; the
    validation's own budget is not touched."""
    from analysis import cli
    from analysis.holes import budget_report
    kept = (budget_report.OUT / "error_budget.csv").read_bytes()
    assert cli.main(["budget", "--preset", "validation", "--out", str(tmp_path)]) == 0
    assert {p.name for p in tmp_path.iterdir()} >= {"error_budget.csv", "error_budget.png"}
    assert f"--out {tmp_path}" in (tmp_path / "error_budget.csv").read_text().splitlines()[0]
    assert (budget_report.OUT / "error_budget.csv").read_bytes() == kept


def test_without_out_a_budget_goes_to_its_presets_default_folder_and_its_stamp_names_no_out(tmp_path, monkeypatch):
    """Without --out the budget lands in `default_out(preset)` (results/validation for bench_validation,
    results/validation/<preset>/ for any other: its doctest), and its stamp is the plain command."""
    from analysis import cli
    from analysis.holes import budget_report
    monkeypatch.setattr(budget_report, "default_out", lambda preset: tmp_path / preset)
    assert cli.main(["budget", "--preset", "validation"]) == 0
    first = (tmp_path / "validation" / "error_budget.csv").read_text().splitlines()[0]
    assert "`./holes budget --preset validation` at" in first and "--out" not in first


def test_the_strip_grain_size_reads_the_named_validations_presets(tmp_path):
    """`bench grain-size --strip validation` reads the cone-fitted strip's three grain sizes from the committed
    comparison, never the bench validation's, and its table's stamp names the validation and the folder."""
    from analysis.batch.bench_reference import STRIP_PRESETS, run_grain_size
    assert run_grain_size(tmp_path, strip="validation") == 0
    text = (tmp_path / "grain_size_strip.csv").read_text()
    assert "--strip validation" in text.splitlines()[0] and f"--out {tmp_path}" in text.splitlines()[0]
    import pandas as pd
    from io import StringIO
    t = pd.read_csv(StringIO(text), comment="#")
    assert set(t.radius_mm) == {4.0, 5.0, 6.0}
    assert not set(STRIP_PRESETS["validation"]) & set(STRIP_PRESETS["bench_validation"])


def test_an_unknown_strip_validation_is_refused_before_anything_runs(capsys):
    from analysis import cli
    with pytest.raises(SystemExit) as e:
        cli.main(["bench", "grain-size", "--strip", "paper"])
    assert e.value.code == 2 and "--strip" in capsys.readouterr().err


def test_the_command_lines_strip_choices_are_the_validations_with_strips():
    """`--strip`'s choices are the validations that name `grain_size` strips in configs/presets.toml, the keys
    bench grain-size reads."""
    from analysis import cli
    from analysis.batch.bench_reference import STRIP_PRESETS
    bench = next(a for a in cli.build_parser()._subparsers._group_actions[0].choices["bench"]._actions
                 if a.dest == "strip")
    assert set(bench.choices) == set(STRIP_PRESETS) and bench.const in STRIP_PRESETS
