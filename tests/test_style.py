"""The house rules a newcomer relies on: ruff passes, and imports run one way between the analysis layers."""
import ast
import subprocess
import sys
from pathlib import Path

import pytest

from analysis.core.schema import ROOT

LAYERS = {"core": 0, "holes": 1, "soil": 1, "pepper": 1, "batch": 2, "cli": 3, "commands": 3, "params_doc": 3}


def layer(module: str) -> int | None:
    """The layer of an `analysis.` module path (analysis.holes.compare -> holes), None outside analysis."""
    parts = module.split(".")
    return LAYERS.get(parts[1]) if parts[0] == "analysis" and len(parts) > 1 else None


def imports(path: Path) -> list[tuple[str, int]]:
    """Every `analysis.` module a file imports, at module level or inside a function, with its line."""
    out = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            out += [(node.module, node.lineno)]
        elif isinstance(node, ast.Import):
            out += [(a.name, node.lineno) for a in node.names]
    return [(m, n) for m, n in out if m.startswith("analysis")]


def test_ruff_passes():
    r = subprocess.run([sys.executable, "-m", "ruff", "check", "analysis", "scripts", "tests"], cwd=ROOT,
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stdout[-3000:]


def arrows():
    for path in sorted((ROOT / "analysis").rglob("*.py")):
        module = ".".join(path.relative_to(ROOT).with_suffix("").parts)
        here = layer(module)
        for target, line in imports(path):
            there = layer(target)
            if here is not None and there is not None and there > here:
                yield f"{path.relative_to(ROOT)}:{line} ({module}) imports {target}"


def test_imports_run_one_way_core_then_holes_soil_pepper_then_batch_then_cli():
    """A module imports only from its own layer or below (core < holes, soil, pepper < batch < cli), at module
    level or inside a function; analysis never imports a scene (scripts/)."""
    against = list(arrows())
    assert not against, "\n".join(against)


def test_analysis_never_imports_a_scene():
    found = [f"{p.relative_to(ROOT)}:{n}" for p in (ROOT / "analysis").rglob("*.py")
             for m, n in [(m, n) for node in ast.walk(ast.parse(p.read_text()))
                          for m, n in ([(node.module, node.lineno)] if isinstance(node, ast.ImportFrom) and node.module
                                       else [(a.name, node.lineno) for a in node.names] if isinstance(node, ast.Import)
                                       else [])]
             if m.startswith("scripts")]
    assert not found, found


@pytest.mark.parametrize("module", ["analysis.holes.compare", "analysis.core.runner", "analysis.cli"])
def test_layer_names(module):
    assert layer(module) is not None
