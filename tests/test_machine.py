"""The machine's calibration on clay (analysis/batch/machine.py): the fit through the design's runs, what it refuses."""
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from analysis import cli
from analysis.batch import machine
from analysis.holes.compare import field_table
from analysis.core.schema import ROOT, ConfigError


def synthetic_rows(points, holes=2, noise=0.3, seed=1):
    """Holes of runs at (P, k): L2_surface = 10 + 0.75 P - 1.5 k and h1 = 20 - 4 k + 0.02 P, with scatter."""
    rng = np.random.default_rng(seed)
    rows = []
    for i, (P, k) in enumerate(points):
        for h in range(holes):
            rows.append({"run": f"r{i}", "P": P, "stiffness": k, "hole": h + 1, "found": True,
                         "L2_surface": 10 + 0.75 * P - 1.5 * k + rng.normal(0, noise),
                         "h1": 20 - 4 * k + 0.02 * P + rng.normal(0, noise)})
    return pd.DataFrame(rows)


def test_the_targets_are_clays_field_means_only():
    want = machine.targets(field_table())
    assert want == pytest.approx({"literal": 62.1 + 13.5, "surface": 62.1, "h1": 13.5})


def test_the_calibration_never_reads_loams_or_sands_field_numbers():
    """Loam's and sand's rows scrambled, or gone: the targets, and so the fitted machine, do not move."""
    field = field_table()
    numbers = field.select_dtypes("number").columns
    scrambled = field.copy()
    other = scrambled.soil != "clay"
    scrambled.loc[other, numbers] = scrambled.loc[other, numbers] * 7.3 + 11.0
    rows = synthetic_rows([(80, 0.5), (80, 2.5), (95, 0.5), (95, 2.5)])
    fits = [machine.fit(rows, machine.targets(f), n_boot=50) for f in (field, scrambled, field[~other])]
    for f in fits[1:]:
        pd.testing.assert_frame_equal(f, fits[0])


def test_the_fit_recovers_the_penetration_and_spring_of_a_known_model():
    want = {"literal": 75.6, "surface": 62.1, "h1": 13.5}
    table = machine.fit(synthetic_rows([(80, 0.5), (80, 2.5), (95, 0.5), (95, 2.5)]), want, n_boot=300)
    for r in table.itertuples():
        # the exact model's answer: solve 0.75 P - 1.5 k = target - 10 and 0.02 P - 4 k = 13.5 - 20
        P, k = np.linalg.solve([[0.75, -1.5], [0.02, -4.0]], [want[r.variant] - 10, 13.5 - 20])
        assert r.P == pytest.approx(P, abs=1.0) and r.stiffness == pytest.approx(k, abs=0.2)
        assert r.P_lo <= r.P <= r.P_hi and r.stiffness_lo <= r.stiffness <= r.stiffness_hi
    statuses = dict(zip(table.variant, table.status))
    assert statuses["literal"] == "resolved"                        # P 91.6, k 2.1: inside the bracket, narrow
    assert statuses["surface"] == "extrapolated beyond the bracket"  # P 73.5: below it


def test_one_penetration_determines_nothing():
    table = machine.fit(synthetic_rows([(80, 0.5), (80, 2.5)]), {"literal": 75.6, "surface": 62.1, "h1": 13.5})
    assert table.status.str.startswith("not determined: 1 penetration(s) and 2 spring rate(s) in 2 run(s)").all()


def test_a_design_on_another_soil_is_refused(tmp_path, capsys):
    design = tmp_path / "loam.toml"
    design.write_text((ROOT / "configs/studies/machine_clay.toml").read_text().replace('soil = "clay"', 'soil = "loam"'))
    with pytest.raises(ConfigError, match="allowed 'clay' only"):
        machine.load_design(design)
    assert cli.main(["calibrate-machine", str(design), "--runs-dir", str(tmp_path / "runs")]) == 2
    assert "allowed 'clay' only" in capsys.readouterr().err and not (tmp_path / "runs").exists()


def test_the_fitted_values_are_written_where_a_preset_reads_them(tmp_path):
    """calibrate-machine's values reach the runs through configs/machine.toml: each variant with a fit is a
    section a preset's `machine` key names; one the design cannot determine is not written."""
    from analysis.core.config import load_machine
    from analysis.batch.study import load_study
    _, cases = load_study(ROOT / "configs/studies/machine_clay.toml")
    want = {"literal": 75.6, "surface": 62.1, "h1": 13.5}
    table = machine.fit(synthetic_rows([(80, 0.5), (80, 2.5), (95, 0.5), (95, 2.5)]), want, n_boot=100)
    path = tmp_path / "machine.toml"
    assert machine.write_machine(table, cases, path, "test", want) == ["literal", "surface"]
    for r in table.itertuples():
        m = load_machine(r.variant, path)
        assert m["tool"]["disk.penetration"] == pytest.approx(r.P, abs=0.05)
        assert m["tool"]["sleeve.stiffness"] == pytest.approx(r.stiffness, abs=0.005)
        assert m["tool"]["sleeve.rest_from_tip"] == 22.0 and m["status"] == r.status
        assert m["source"].startswith("calibrated on clay, seed 001 Table 3")
        assert m["fit"] == "results/calibration/machine_fit.csv"        # where the budget finds the fit's design
    undetermined = machine.fit(synthetic_rows([(80, 0.5), (80, 2.5)]), want)
    assert machine.write_machine(undetermined, cases, tmp_path / "none.toml", "test", want) == []
    assert not (tmp_path / "none.toml").exists()


def test_adopting_one_variant_rewrites_its_section_and_keeps_the_others(tmp_path):
    """`--adopt literal` writes the literal section from this fit and leaves the surface section (another design's
    fit) as it was; each section names the command that made it; an unknown variant is refused."""
    from analysis.core.config import load_machine
    from analysis.batch.study import load_study
    _, cases = load_study(ROOT / "configs/studies/machine_clay.toml")
    want = {"literal": 75.6, "surface": 62.1, "h1": 13.5}
    path = tmp_path / "machine.toml"
    first = machine.fit(synthetic_rows([(80, 0.5), (80, 2.5), (95, 0.5), (95, 2.5)]), want, n_boot=100)
    assert machine.write_machine(first, cases, path, "made by `first`", want) == ["literal", "surface"]
    surface = load_machine("surface", path)
    deeper = {**want, "literal": 78.0}
    second = machine.fit(synthetic_rows([(80, 0.5), (80, 2.5), (95, 0.5), (95, 2.5)]), deeper, n_boot=100)
    only = second[second.variant.isin(machine.adopted_variants("literal"))]
    assert machine.write_machine(only, cases, path, "made by `second`", deeper) == ["literal"]
    assert load_machine("surface", path) == surface and surface["made_by"] == "`first`"
    literal = load_machine("literal", path)
    assert literal["made_by"] == "`second`"
    assert literal["tool"]["disk.penetration"] == pytest.approx(second.set_index("variant").P["literal"], abs=0.05)
    assert second.set_index("variant").P["literal"] > first.set_index("variant").P["literal"] + 1   # a deeper target
    with pytest.raises(ConfigError, match="'deep' is not a variant"):
        machine.adopted_variants("literal,deep")


def test_the_bench_clays_fit_gets_its_own_sections_beside_the_cone_fitted_clays(tmp_path):
    """A design on the bench-calibrated soils (its preset's soils = "bench") writes bench_literal and bench_surface,
    each naming its variant, and leaves the cone-fitted clay's literal and surface, which other presets run, as they
    were; the section's `variant` names its row of the fit (where the budget looks it up)."""
    from analysis.core.config import load_machine
    from analysis.batch.study import load_study
    _, cone = load_study(ROOT / "configs/studies/machine_clay.toml")
    bench = machine.load_design(ROOT / "configs/studies/machine_clay_bench.toml")
    want = {"literal": 75.6, "surface": 62.1, "h1": 13.5}
    table = machine.fit(synthetic_rows([(80, 0.5), (80, 2.5), (95, 0.5), (95, 2.5)]), want, n_boot=100)
    path = tmp_path / "machine.toml"
    assert machine.write_machine(table, cone, path, "made by `cone`", want) == ["literal", "surface"]
    surface = load_machine("surface", path)
    deeper = machine.fit(synthetic_rows([(80, 0.5), (80, 2.5), (95, 0.5), (95, 2.5)]), {**want, "surface": 66.0},
                         n_boot=100)
    assert machine.write_machine(deeper, bench, path, "made by `bench`", want) == ["bench_literal", "bench_surface"]
    assert load_machine("surface", path) == surface
    bench_surface = load_machine("bench_surface", path)
    assert bench_surface["variant"] == "surface" and bench_surface["made_by"] == "`bench`"
    assert bench_surface["tool"]["disk.penetration"] > surface["tool"]["disk.penetration"] + 1   # its own, deeper fit


def test_a_design_mixing_the_cone_fitted_and_the_bench_clay_is_refused(tmp_path):
    design = (ROOT / "configs/studies/machine_clay_bench.toml").read_text()
    mixed = tmp_path / "mixed.toml"
    mixed.write_text(design + '\n[[case]]\npreset = "validation_medium"\n"disk.penetration" = 80.0\n'
                     '"sleeve.stiffness" = 2.0\nseed = 1\n')
    with pytest.raises(ConfigError, match="different soil sets"):
        machine.load_design(mixed)


def test_a_calibrated_preset_runs_the_calibrated_machine_and_the_others_keep_their_ids():
    import json
    from analysis.core.config import load_machine
    from analysis.core.run_spec import plan
    for preset in ("validation_surface", "validation_literal"):
        p = plan("clay", preset)
        tool = load_machine(p["preset"]["machine"])["tool"]
        assert p["disk"]["penetration"] == tool["disk.penetration"]
        assert p["sleeve"]["stiffness"] == tool["sleeve.stiffness"]
        assert p["awake_mm"] == [60.0, 120.0] and p["preset"]["holes"] == 8
    # a preset without `machine` or `awake` plans the run it planned before they existed (a kept run's id)
    kept = ROOT / "tests/data/kept_run/config.json"
    assert plan("clay", "quick")["id"] == json.loads(kept.read_text())["id"]


def test_the_load_is_read_from_the_first_measured_hole_on_a_strip_longer_than_the_disk(tmp_path):
    """W averages the soil's vertical force over the measured holes' punch periods, from the first measured
    hole's punch at its lowest. On a strip of more holes than punches that punch passes twice: the first
    pass is the one (a synthetic record: each hole's punch pushes up with 100 N × its hole number)."""
    import math
    omega, n, period = 4.0, 6, 2 * math.pi / 4.0 / 6
    rows = []
    for hole in range(9):                                   # lead-in + 8 measured, punches 0..5 then 0..2 again
        for phi in np.linspace(50, -50, 41) + (0.3 if hole == 1 else 0.0):     # hole 7 is nearer 0° than hole 1
            t = hole * period + math.radians(50 - phi) / omega
            rows.append({"t_s": t, "punch": hole % n, "phi_deg": phi, "omega_rad_s": omega,
                         "punch_fz_n": 100.0 * hole, "sleeve_force_n": 0.0})
    ts = pd.DataFrame(rows).sort_values("t_s")
    ts.to_csv(tmp_path / "timeseries.csv", index=False)
    w = machine.vertical_load(tmp_path, lead_in=1, holes=8)
    # from hole 1's bottom, 8 periods: the second half of hole 1's passage, holes 2-8 whole, the first half of
    # hole 9's (none: it has no record); each passage lasts 100°/ω of the period's 60°/ω
    dt = float(np.median(np.diff(np.unique(ts.t_s))))
    in_soil = 41 * dt
    expected = (100 * 1 * in_soil / 2 + sum(100 * h * in_soil for h in range(2, 9))) / (8 * period)
    assert w == pytest.approx(expected, rel=0.05)


def test_a_strip_whose_punches_turn_twice_is_a_new_run():
    """A punch on its second turn works its sleeve (its angle is wrapped): the runs of strips longer than N
    holes carry the mark, those of shorter strips keep their ids."""
    from analysis.core.kinematics import wrapped
    from analysis.core.run_spec import plan
    assert wrapped(0.3 - 2 * np.pi) == pytest.approx(0.3) and wrapped(np.pi) == pytest.approx(-np.pi)
    assert plan("clay", "validation_surface")["punch_turns"] == 2
    assert "punch_turns" not in plan("clay", "quick", holes=5)            # lead-in + 5 = 6 holes, one turn
    assert plan("clay", "validation_surface")["id"] != "clay-validation_surface-prescribed-ed36d653"


def packing_rows(points, packings=2, holes=8, packing_sd=1.5, hole_sd=2.0, seed=3):
    """Holes of the made-up model of synthetic_rows on several packings per point: each packing shifts its holes'
    L2_surface and h1 by its own offset (packing_sd), each hole scatters about it (hole_sd)."""
    rng = np.random.default_rng(seed)
    rows = []
    for i, (P, k) in enumerate(points):
        for s in range(packings):
            off = rng.normal(0, packing_sd, 2)
            for h in range(holes):
                rows.append({"run": f"r{i}s{s}", "P": P, "stiffness": k, "hole": h + 1, "found": True,
                             "L2_surface": 10 + 0.75 * P - 1.5 * k + off[0] + rng.normal(0, hole_sd),
                             "h1": 20 - 4 * k + 0.02 * P + off[1] + rng.normal(0, hole_sd)})
    return pd.DataFrame(rows)


def test_the_fit_recovers_made_up_values_through_made_up_packing_scatter():
    """Two packings of 8 holes at each of four points, the packings scattering as real ones do: the fit lands near the
    made-up machine, its interval holds it, and the status is "resolved" (inside the design, intervals narrower than
    it); with one packing per point and the same scatter the interval is wider."""
    want = {"literal": 10 + 0.75 * 88 - 1.5 * 1.8, "surface": 10 + 0.75 * 88 - 1.5 * 1.8, "h1": 20 - 4 * 1.8 + 0.02 * 88}
    design = [(80, 0.5), (80, 3.0), (95, 0.5), (95, 3.0)]
    two = machine.fit(packing_rows(design), want, n_boot=400).set_index("variant").loc["surface"]
    assert two.P == pytest.approx(88, abs=3) and two.stiffness == pytest.approx(1.8, abs=0.5)
    assert two.P_lo <= 88 <= two.P_hi and two.stiffness_lo <= 1.8 <= two.stiffness_hi
    assert two.status == "resolved" and two.packings_per_point == 2
    one = machine.fit(packing_rows(design, packings=1, holes=16), want, n_boot=400).set_index("variant").loc["surface"]
    assert one.packings_per_point == 1
    for name in ("P", "stiffness"):
        assert two[f"{name}_hi"] - two[f"{name}_lo"] > 0.5 * (one[f"{name}_hi"] - one[f"{name}_lo"])


def test_a_fit_inside_the_design_with_an_interval_wider_than_it_is_not_resolved():
    means = pd.DataFrame({"P": [80, 80, 95, 95], "stiffness": [0.5, 3.0, 0.5, 3.0]})
    assert machine.status_of(88, 1.8, (85, 91), (1.0, 2.5), means) == "resolved"
    assert machine.status_of(88, 1.8, (70, 100), (1.0, 2.5), means).startswith("inside the bracket, not resolved")
    assert machine.status_of(78, 1.8, (75, 81), (1.0, 2.5), means) == "extrapolated beyond the bracket"
    assert machine.status_of(88, -0.1, (85, 91), (-1, 0.5), means) == "not physical: a negative spring rate"


def test_the_sections_show_the_first_packings_points_deepest_first_and_skip_runs_without_grains(tmp_path, monkeypatch):
    """calibrate-machine's sections.png: one panel per design point of the first packing with grains, the deepest
    punch on top; a run kept without its grains, or on another packing, draws nothing."""
    import shutil
    from types import SimpleNamespace
    import analysis.holes.run_report as report
    runs = {}
    for name in ("a", "b", "no_grains"):
        runs[name] = Path(shutil.copytree(ROOT / "tests/data/kept_run", tmp_path / name))
    (runs["no_grains"] / "state.npz").unlink()

    def case(p, k, seed):
        return SimpleNamespace(fields={machine.P_KEY: p, machine.K_KEY: k}, params={"seed": seed})
    drawn, draw = [], report.sections
    monkeypatch.setattr(report, "sections", lambda folders, labels, out: drawn.append(labels) or draw(folders, labels, out))
    found = [(case(80, 1, 1), runs["a"]), (case(95, 4, 1), runs["b"]), (case(88, 1, 1), runs["no_grains"]),
             (case(95, 1, 2), runs["a"])]
    path = machine.draw_sections(found, tmp_path / "sections.png")
    assert drawn == [["P 95 mm, spring 4 N/mm, packing 1", "P 80 mm, spring 1 N/mm, packing 1"]]
    assert path.exists() and path.stat().st_size > 10_000
    assert machine.draw_sections([(case(80, 1, 1), runs["no_grains"])], tmp_path / "none.png") is None


def test_adopt_writes_the_fit_where_the_presets_read_it(monkeypatch, capsys):
    """--adopt sends a fit made in another --out folder to configs/machine.toml (every variant, or those it names);
    without it that folder keeps it; a variant that does not exist is refused before anything runs."""
    from analysis.core.config import MACHINE
    seen = []
    monkeypatch.setattr(machine, "run", lambda *a, machine_path=None, variants=None, **k:
                        seen.append((machine_path, variants)) or 0)
    for extra in (["--adopt"], ["--adopt", "literal"], []):
        assert cli.main(["calibrate-machine", "configs/studies/machine_clay_r6.toml", "--out", "results/x",
                         "--no-run", *extra]) == 0
    assert seen == [(ROOT / MACHINE, ("literal", "surface")), (ROOT / MACHINE, ("literal",)),
                    (None, ("literal", "surface"))]
    assert cli.main(["calibrate-machine", "configs/studies/machine_clay_r6.toml", "--no-run", "--adopt", "deep"]) == 2
    assert "'deep' is not a variant" in capsys.readouterr().err and len(seen) == 3


def test_an_adopted_fit_also_keeps_its_folders_own_record(tmp_path, monkeypatch):
    """`--adopt surface --out F`: configs/machine.toml gets the surface section only, and F/machine.toml, the folder's
    record of its fit, gets every variant the fit determined, so the two never disagree with F/machine_fit.csv."""
    from analysis.batch import compare_job
    from analysis.core.config import load_machine
    cases = machine.load_design(ROOT / "configs/studies/machine_clay_r6.toml")

    def rows(case, folder):
        one = synthetic_rows([(case.fields[machine.P_KEY], case.fields[machine.K_KEY])], holes=4, seed=case.fields["seed"])
        return one.assign(run=case.id, seed=case.fields["seed"])
    monkeypatch.setattr(machine, "finished", lambda runs_dir, run_id: True)
    monkeypatch.setattr(machine, "run_rows", rows)
    monkeypatch.setattr(machine, "draw_sections", lambda found, path: None)
    monkeypatch.setattr(compare_job, "keep", lambda src, dst: None)
    adopted, out = tmp_path / "configs_machine.toml", tmp_path / "fit"
    assert machine.run(ROOT / "configs/studies/machine_clay_r6.toml", runs_dir=tmp_path, out=out, no_run=True,
                       machine_path=adopted, variants=("surface",)) == 0
    assert sorted(machine.sections_of(adopted.read_text())) == ["surface"]
    assert sorted(machine.sections_of((out / "machine.toml").read_text())) == ["literal", "surface"]
    assert load_machine("surface", adopted)["tool"] == load_machine("surface", out / "machine.toml")["tool"]
    assert len(cases) == len(pd.read_csv(out / "machine.csv", comment="#").run.unique())
