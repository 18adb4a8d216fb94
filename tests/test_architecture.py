"""The layering of DESIGN §2, checked on the source: who may import whom, and what at import time."""

from __future__ import annotations

import ast
import json
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "fuzzyfeed"
HEAVY = ("matplotlib", "pandas", "ezdxf", "skfuzzy", "tqdm", "panel", "bokeh", "tomlkit", "dask", "distributed")


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


#: The flow as layers (README, *How it is built*): a module may import its own package and the
#: layers below it, never a layer above; the two planners sit side by side and never import each
#: other. Every module of the package is in exactly one layer.
LAYERS = {
    "errors": 0,
    "base": 1,
    "geometry": 2,
    "machine": 3,
    "fuzzy": 4, "slw": 4,
    "program": 5,
    "io": 6,
    "report": 7,
    "advice": 8,
    "batch": 9, "designer": 9,
    "cli": 10,
    "__main__": 11,
}


def layer_of(module: str) -> tuple[str, int] | None:
    """(package, layer) of a fuzzyfeed module name, or None for the package itself."""
    parts = module.split(".")
    if parts[0] != "fuzzyfeed" or len(parts) == 1:
        return None
    return parts[1], LAYERS[parts[1]]


def test_every_package_has_a_layer():
    tops = {p.stem if p.is_file() else p.name for p in PACKAGE.iterdir()
            if (p.suffix == ".py" or (p / "__init__.py").is_file()) and p.name != "__init__.py"}
    assert tops <= set(LAYERS), f"not in a layer: {sorted(tops - set(LAYERS))}"
    loose = sorted(p.name for p in PACKAGE.glob("*.py") if p.stem not in ("__init__", "__main__", "errors"))
    assert not loose, f"modules loose at the top of the package: {loose}"


@pytest.mark.parametrize("path", sources(), ids=lambda p: str(p.relative_to(PACKAGE)))
def test_layering(path):
    rel = path.relative_to(PACKAGE)
    parts = rel.with_suffix("").parts
    if parts[-1] == "__init__":
        parts = parts[:-1]
    own = layer_of(".".join(("fuzzyfeed", *parts)))
    if own is None:          # fuzzyfeed/__init__.py: the public API, imported lazily
        return
    package, rank = own
    for name in module_imports(path, top_level_only=False):
        other = layer_of(name) if name.startswith("fuzzyfeed.") else None
        if other is None or other[0] == package:
            continue
        assert other[1] < rank, (f"{rel} (layer {rank}, {package}) imports {name} "
                                 f"(layer {other[1]}, {other[0]}): a layer never imports one above or beside it")


def test_a_package_init_says_what_it_may_import():
    for init in sorted(PACKAGE.glob("*/__init__.py")):
        doc = ast.get_docstring(ast.parse(init.read_text())) or ""
        assert "import" in doc.lower(), f"{init.relative_to(PACKAGE)}: its docstring must say what it may import"


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


@pytest.mark.parametrize("path", [p for p in sources() if p.relative_to(PACKAGE).parts[0] not in ("cli", "__main__.py")],
                         ids=lambda p: str(p.relative_to(PACKAGE)))
def test_the_command_line_stays_in_cli(path):
    """Issue 39: argparse and its Namespace end in ``cli/``; no module outside it imports argparse or
    the command line, or names them (``__main__.py``, the entry point, only calls ``cli.main``)."""
    imports = module_imports(path, top_level_only=False)
    assert not {name for name in imports if name == "argparse" or name.startswith("fuzzyfeed.cli")}, imports
    text = path.read_text()
    assert "argparse" not in text and "fuzzyfeed.cli" not in text, f"{path.relative_to(PACKAGE)} names the command line"
