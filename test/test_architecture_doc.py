"""docs/architecture.md is the map of the code: its generated parts are current, every package is on it."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOC = ROOT / "docs" / "architecture.md"


def generator() -> ModuleType:
    """docs/make_architecture.py, imported by path (docs/ is not a package)."""
    spec = importlib.util.spec_from_file_location("make_architecture", ROOT / "docs" / "make_architecture.py")
    assert spec and spec.loader
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def between(text: str, markers: tuple[str, str]) -> str:
    return text.split(markers[0], 1)[1].split(markers[1], 1)[0]


def written_by_hand(text: str, make: ModuleType) -> str:
    """The page without its generated parts (they name every package whatever the prose says)."""
    for markers in (make.CONTRACTS_MARKERS, make.GRAPH_MARKERS, make.FACTS_MARKERS):
        text = text.replace(between(text, markers), "\n")
    return text


@pytest.mark.parametrize(
    ("markers", "make_part"),
    [("CONTRACTS_MARKERS", "contracts_block"), ("GRAPH_MARKERS", "graph_block"), ("FACTS_MARKERS", "facts_block")],
    ids=["import-linter contracts", "import graph", "facts of each spec"],
)
def test_each_generated_part_of_the_page_is_what_the_code_makes_now(markers, make_part):
    make = generator()
    on_page = between(DOC.read_text(), getattr(make, markers)).strip()
    assert on_page == getattr(make, make_part)().strip(), "docs/architecture.md is stale: run make architecture"


def test_every_top_level_package_is_described_in_the_pages_own_words():
    make = generator()
    packages = [path.parent.name for path in ROOT.glob("*/__init__.py")]
    assert {"sim_runtime", "create_sim", "simrobot_sim", "arm_sim", "sim_tools", "studio"} <= set(packages)
    prose = written_by_hand(DOC.read_text(), make)
    missing = sorted(package for package in packages if f"`{package}/`" not in prose)
    assert not missing, f"docs/architecture.md does not describe these packages (as `name/`): {missing}"


def test_the_generator_finds_a_new_top_level_package_and_draws_its_imports(tmp_path):
    make = generator()
    (tmp_path / "newpkg").mkdir()
    (tmp_path / "newpkg" / "__init__.py").write_text("")
    (tmp_path / "notes").mkdir()  # a folder without __init__.py is not a package
    assert make.top_level_packages(tmp_path) == ["newpkg"]
    edges = [("studio.create.page", "sim_tools.batch.cli"), ("studio.create.page", "studio.shell.kit")]
    assert make.package_edges(edges) == {("studio", "sim_tools"): 1}
    inside = {("studio.create", "sim_tools"): 1, ("studio.create", "studio.shell"): 1}
    assert make.members_edges("studio", edges) == inside
