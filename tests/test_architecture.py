"""The layering of DESIGN §2, checked on the source: who may import whom, and what at import time."""

from __future__ import annotations

import ast
import json
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "fuzzyfeed"
CORE = ("nurbs", "sampling", "profile", "limits", "interpolate", "servo", "simulate", "errors", "_kernels",
        "_nurbs_jit")
HEAVY = ("matplotlib", "pandas", "ezdxf", "skfuzzy", "tqdm")


def module_imports(path: Path, top_level_only: bool) -> set[str]:
    tree = ast.parse(path.read_text())
    nodes = tree.body if top_level_only else list(ast.walk(tree))
    names: set[str] = set()
    for node in nodes:
        if isinstance(node, ast.Import):
            names |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
    return names


def sources(sub: str = "") -> list[Path]:
    return sorted((PACKAGE / sub).rglob("*.py")) if sub else sorted(PACKAGE.rglob("*.py"))


@pytest.mark.parametrize("path", sources(), ids=lambda p: str(p.relative_to(PACKAGE)))
def test_layering(path):
    rel = path.relative_to(PACKAGE)
    imports = module_imports(path, top_level_only=False)
    planners = {i for i in imports if i.startswith(("fuzzyfeed.fuzzy", "fuzzyfeed.slw", "fuzzyfeed.compare"))}
    if rel.parts[0] == "fuzzy":
        assert not {i for i in planners if i.startswith(("fuzzyfeed.slw", "fuzzyfeed.compare"))}
    elif rel.parts[0] == "slw":
        assert not {i for i in planners if i.startswith(("fuzzyfeed.fuzzy", "fuzzyfeed.compare"))}
    elif rel.stem in CORE and len(rel.parts) == 1:
        assert not planners, f"core module {rel} imports {planners}"


@pytest.mark.parametrize("path", sources(), ids=lambda p: str(p.relative_to(PACKAGE)))
def test_no_heavy_imports_at_module_level(path):
    top = module_imports(path, top_level_only=True)
    heavy = {i for i in top if i.split(".")[0] in HEAVY}
    assert not heavy, f"{path.relative_to(PACKAGE)} imports {heavy} at import time"


@pytest.mark.parametrize("notebook", sorted((PACKAGE.parent / "notebooks").glob("*.ipynb")),
                         ids=lambda p: p.name)
def test_notebooks_are_stripped(notebook):
    cells = json.loads(notebook.read_text())["cells"]
    for cell in cells:
        if cell["cell_type"] == "code":
            assert cell.get("outputs") == [] and cell.get("execution_count") is None
