"""The calibration search and the config write-back, on known functions (no YADE)."""
import shutil

import pytest

from analysis import calibrate
from analysis.config import ROOT, load_soil

quiet = dict(log=lambda *a: None)


@pytest.mark.parametrize("f,target", [(lambda x: 2 * x + 1, 11.0), (lambda x: 300 + x ** 1.5 / 100, 450.0),
                                      (lambda x: 1e5 * (1 - 2.718 ** (-x / 3e4)) + 2e5, 2.6e5)])
def test_search_lands_within_tolerance(f, target):
    x, y, history = calibrate.bracket_search(f, target, 0.0, 1e5, **quiet)
    assert abs(y / target - 1) <= calibrate.TOLERANCE
    assert y == f(x) and len(history) <= 10


def test_unreachable_target_is_an_error_naming_the_value():
    with pytest.raises(ValueError, match="already 500 at the lower bound 0, above the target 450"):
        calibrate.bracket_search(lambda x: 500 + x, 450.0, 0.0, 10.0, **quiet)
    with pytest.raises(ValueError, match="only 20 at the upper bound 10, below the target 450"):
        calibrate.bracket_search(lambda x: 10 + x, 450.0, 0.0, 10.0, **quiet)


def test_write_back_keeps_comments_and_validates(tmp_path, monkeypatch):
    soils = tmp_path / "configs/soils"
    soils.mkdir(parents=True)
    (tmp_path / "configs/field").mkdir()
    shutil.copy(ROOT / "configs/soils/sand.toml", soils / "sand.toml")
    shutil.copy(ROOT / "configs/field/table2_soils.csv", tmp_path / "configs/field/table2_soils.csv")
    monkeypatch.setattr(calibrate, "ROOT", tmp_path)
    import analysis.config as config
    monkeypatch.setattr(config, "ROOT", tmp_path)
    calibrate.write_back("sand", ("normal_cohesion", "shear_cohesion"), 12345.0)
    text = (soils / "sand.toml").read_text()
    assert "normal_cohesion = 1.234e+04  # Pa, tensile bond strength" in text
    s = load_soil(soils / "sand.toml")
    assert s.normal_cohesion == s.shear_cohesion == pytest.approx(12340.0)
