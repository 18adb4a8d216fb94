"""The G-code side's layout (issue 15 §5): no import circle among fuzzyfeed's modules, readers
import the one Shape module and never the dispatcher, reading and writing apart, knot insertion in
the NURBS core."""

from __future__ import annotations

from test_architecture import PACKAGE, module_imports


def _graph() -> dict[str, set[str]]:
    graph = {}
    for path in PACKAGE.rglob("*.py"):
        rel = path.relative_to(PACKAGE.parent).with_suffix("")
        name = ".".join(rel.parts).removesuffix(".__init__")
        graph[name] = {m for m in module_imports(path, top_level_only=False) if m.startswith("fuzzyfeed.")}
    return graph


def test_no_import_circle():
    graph = _graph()
    state: dict[str, int] = {}

    def visit(node, stack):
        state[node] = 1
        for nxt in sorted(graph.get(node, ())):
            if nxt not in graph or nxt == "fuzzyfeed":
                continue
            if state.get(nxt) == 1:
                raise AssertionError("import circle: " + " -> ".join(stack + [node, nxt]))
            if state.get(nxt) is None:
                visit(nxt, stack + [node])
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            visit(node, [])


def test_readers_import_the_shape_module_not_the_dispatcher():
    graph = _graph()
    for reader in ("fuzzyfeed.io.points", "fuzzyfeed.io.dxf", "fuzzyfeed.io.gcode_paths"):
        assert "fuzzyfeed.io.shape" in graph[reader]
        assert "fuzzyfeed.io.shapes" not in graph[reader]
    # reading and writing apart; knot insertion in the core
    assert not {m for m in graph["fuzzyfeed.program.read"] if "write" in m or "rewrite" in m}
    assert "fuzzyfeed.program.read" not in graph["fuzzyfeed.program.rewrite"]
    from fuzzyfeed.geometry import nurbs
    assert callable(nurbs.insert_knot) and callable(nurbs.bezier_segments)
