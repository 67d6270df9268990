"""The floor plan's rules that import-linter does not check (it checks the layers: `make lint`)."""

from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
#: Every folder of code outside the tests (the test-only toy simulator included).
CODE = ("sim_runtime", "create_sim", "simrobot_sim", "arm_sim", "sim_tools", "studio", "bench", "examples", "docs")
#: The tools that reach the simulators through the registry only.
REGISTRY_TOOLS = ("batch", "fuzz", "fuzz_kit", "rerun_view", "rerun_kit", "demo.py", "warmup.py")
LONGEST_FUNCTION = 80
SIMULATOR_BRANCH = re.compile(r"""simulator\s*[!=]=|[!=]=\s*["'](create|simrobot|arm)["']|\bis_create\b""")


def python_files(*folders: str) -> list[Path]:
    return sorted(p for folder in (*folders, "test/toy_sim") for p in (ROOT / folder).rglob("*.py"))


def functions(path: Path) -> list[tuple[str, int]]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    kinds = (ast.FunctionDef, ast.AsyncFunctionDef)
    return [(n.name, n.end_lineno - n.lineno + 1) for n in ast.walk(tree) if isinstance(n, kinds) and n.end_lineno]


def test_no_function_outside_the_tests_is_longer_than_80_lines():
    files = python_files(*CODE)
    too_long = [
        f"{path.relative_to(ROOT)}:{name} ({lines} lines)"
        for path in files
        for name, lines in functions(path)
        if lines > LONGEST_FUNCTION
    ]
    assert len(files) > 150 and too_long == []


def test_the_tools_over_the_registry_name_no_simulator_in_a_branch():
    tools = [ROOT / "sim_tools" / tool for tool in REGISTRY_TOOLS]
    files = [p for tool in tools for p in ([tool] if tool.suffix == ".py" else sorted(tool.rglob("*.py")))]
    branches = [
        f"{path.relative_to(ROOT)}:{number}: {line.strip()}"
        for path in files
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
        if SIMULATOR_BRANCH.search(line)
    ]
    assert len(files) > 20 and branches == []
