"""The package's layers, checked by static import analysis (ast) of every module of `pcbdata/`.

Every module belongs to a room (a subpackage, or a top-level module) and every room to a layer
of `LAYERS`, from the bottom up. A module may import from its own room, from rooms of its own
layer and from rooms below; every import counts, including those inside functions and under
`TYPE_CHECKING`. No two modules import each other, directly or around a circle. DEVELOPERS.md
describes the same table.
"""
from __future__ import annotations

import ast
from pathlib import Path

from tests.conftest import REPO_ROOT

PACKAGE = REPO_ROOT / "pcbdata"

#: From the bottom up: what each room is for is in DEVELOPERS.md ("Layers").
LAYERS = (
    ("pcbdata.core", "pcbdata.resources"),
    ("pcbdata.kicad", "pcbdata.router", "pcbdata.model"),
    ("pcbdata.generators", "pcbdata.executors"),
    ("pcbdata.sets",),
    ("pcbdata.curation", "pcbdata.realism", "pcbdata.board_render"),
    ("pcbdata.publish",),
    ("pcbdata.sets.verify", "pcbdata.build", "pcbdata.evaluator", "pcbdata.baselines"),
    ("pcbdata.env",),
    ("pcbdata.env.wrappers", "pcbdata.env.llm"),
    ("pcbdata.agents", "pcbdata.learn"),
    ("pcbdata.runners", "pcbdata.cli", "pcbdata", "pcbdata.__main__"),
    ("pcbdata.testing",),
)
#: `from pcbdata import __version__` is metadata, not a layer.
METADATA = {"pcbdata.__version__"}


def module_of(path: Path) -> str:
    parts = path.relative_to(REPO_ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def room_of(module: str) -> str:
    """The longest room of `LAYERS` that holds `module`."""
    rooms = [room for layer in LAYERS for room in layer
             if module == room or module.startswith(room + ".")]
    return max(rooms, key=len)


def layer_of(room: str) -> int:
    return next(i for i, layer in enumerate(LAYERS) if room in layer)


def package_imports(path: Path) -> list[tuple[int, str]]:
    """(line, module) of every import of a pcbdata module in a file, nested ones included;
    `from pcbdata.x import y` names `pcbdata.x.y` when that is a module."""
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names if a.name.startswith("pcbdata")]
        elif isinstance(node, ast.ImportFrom) and (node.module or "").startswith("pcbdata"):
            assert node.level == 0, f"{path}:{node.lineno}: relative import"
            for alias in node.names:
                name = f"{node.module}.{alias.name}"
                out.append((node.lineno, name if _is_module(name) or name in METADATA
                            else node.module))
    return out


def _is_module(name: str) -> bool:
    path = REPO_ROOT / name.replace(".", "/")
    return path.with_suffix(".py").is_file() or (path / "__init__.py").is_file()


def _graph() -> dict[str, set[str]]:
    graph: dict[str, set[str]] = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        module = module_of(path)
        graph[module] = {name for _, name in package_imports(path)
                         if name not in METADATA and name != module and _is_module(name)}
    return graph


def test_every_module_has_a_room():
    for path in PACKAGE.rglob("*.py"):
        room_of(module_of(path))  # raises when none holds it


def test_no_module_imports_a_room_above_its_own():
    bad = []
    for path in sorted(PACKAGE.rglob("*.py")):
        module = module_of(path)
        own = layer_of(room_of(module))
        for line, name in package_imports(path):
            if name in METADATA or name == "pcbdata":
                continue
            if layer_of(room_of(name)) > own:
                bad.append(f"{path.relative_to(REPO_ROOT)}:{line}: {room_of(module)} "
                           f"(layer {own}) imports {name} (layer {layer_of(room_of(name))})")
    assert not bad, "upward imports:\n" + "\n".join(bad)


def strongly_connected(graph: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's components of more than one module (or a module importing itself)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for nxt in sorted(graph.get(node, ())):
            if nxt not in index:
                visit(nxt)
                low[node] = min(low[node], low[nxt])
            elif nxt in on_stack:
                low[node] = min(low[node], index[nxt])
        if low[node] == index[node]:
            component = []
            while True:
                top = stack.pop()
                on_stack.discard(top)
                component.append(top)
                if top == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return found


def test_no_import_cycle():
    # a package's __init__ re-exporting its modules is not a cycle of the code
    graph = {m: {n for n in deps if not m.startswith(n + ".")} for m, deps in _graph().items()}
    assert strongly_connected(graph) == []


def test_the_checks_can_fail():
    assert strongly_connected({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [
        ["a", "b", "c"]]
    assert layer_of(room_of("pcbdata.env.wrappers.rl")) > layer_of(room_of("pcbdata.env.env"))
    assert room_of("pcbdata.core.errors") == "pcbdata.core"
