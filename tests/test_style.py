"""The house rules a newcomer relies on: ruff passes, imports run one way between the analysis layers, and every
link between the project's pages leads somewhere."""
import ast
import functools
import re
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


def heading_anchor(heading: str) -> str:
    """A Markdown heading's anchor as GitHub makes it: lower case, code ticks and punctuation dropped, spaces as
    hyphens.

    >>> heading_anchor("### The soil's bond (`soil_bond.csv`)")
    'the-soils-bond-soil_bondcsv'
    """
    text = heading.lstrip("#").strip().replace("`", "").lower()
    return re.sub(r"[^\w\- ]", "", text).replace(" ", "-")


@functools.cache
def page_anchors(page: Path) -> frozenset[str]:
    """The anchors of every heading of a Markdown page, read once per page."""
    return frozenset(heading_anchor(line) for line in page.read_text().splitlines() if line.startswith("#"))


def page_links(page: Path) -> list[tuple[Path, str, str]]:
    """Every relative link of a page: (the file it names, the anchor or "", the link as written)."""
    out = []
    for link in re.findall(r"\]\(([^)\s]+)\)", page.read_text()):
        if re.match(r"[a-z]+:", link):
            continue
        path, _, anchor = link.partition("#")
        out.append(((page.parent / path).resolve() if path else page, anchor, link))
    return out


PAGES = [ROOT / "README.md", ROOT / "CHANGELOG.md", ROOT / "configs/README.md",
         *sorted((ROOT / "results").rglob("README.md"))]


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_link_between_the_pages_leads_to_a_file_and_heading(page):
    broken = []
    for target, anchor, link in page_links(page):
        if not target.exists():
            broken.append(f"{link}: no such file")
        elif anchor and target.suffix == ".md" and anchor not in page_anchors(target):
            broken.append(f"{link}: no such heading")
    assert not broken, broken


def test_a_link_to_a_missing_heading_is_found(tmp_path):
    page = tmp_path / "README.md"
    page.write_text("# Top\n\n[up](#top) [gone](#nowhere) [file](other.md)\n")
    assert [(t.name, a) for t, a, _ in page_links(page)] == [("README.md", "top"), ("README.md", "nowhere"),
                                                              ("other.md", "")]
    assert "top" in page_anchors(page) and "nowhere" not in page_anchors(page)
