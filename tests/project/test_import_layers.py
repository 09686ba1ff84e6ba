"""The import graph of rtsim has no circles and no arrow from a lower layer to a higher one.

The rule: the nodes are the modules of ``rtsim`` (each ``.py`` file; a package is its
``__init__.py``); an edge is any import of another rtsim module, at module level or inside a
function, except under ``if TYPE_CHECKING:``; ``from rtsim.pkg import name`` points at the
module that defines ``name`` (a submodule of that name, else the module that binds it,
following re-exports); ``rtsim/__init__.py`` (and ``__main__``) is a facade above everything,
and no module inside rtsim imports the top-level ``rtsim`` package. The layers, bottom up, are
:data:`LAYERS` (docs/architecture.md draws them).
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from functools import cache
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2] / "rtsim"

#: Layers, bottom up: a module may import modules of its own layer or below. The first
#: matching prefix decides (most specific first).
LAYERS: tuple[tuple[str, tuple[str, ...]], ...] = (
    # helpers every layer may use: errors, numbers, the plug-in registry, the file helpers of
    # rtsim.io (atomic writes, result stores, the range table and work limits every layer
    # checks against; the loaders of input files are in config), the notebook display mixin
    (
        "base",
        (
            "rtsim._version",
            "rtsim.errors",
            "rtsim._numbers",
            "rtsim._suggest",
            "rtsim.registry",
            "rtsim.io",
            "rtsim.notebook",
        ),
    ),
    ("model", ("rtsim.model",)),
    ("analysis", ("rtsim.analysis",)),
    ("world / sim / control", ("rtsim.world", "rtsim.sim", "rtsim.control")),
    ("config", ("rtsim.config", "rtsim.overrides", "rtsim.examples")),
    ("coupling", ("rtsim.coupling",)),
    ("sweep / plots / export", ("rtsim.sweep", "rtsim.plots", "rtsim.export", "rtsim.animate")),
    (
        "validate / reproduce",
        ("rtsim.validate", "rtsim.reproduce", "rtsim.report", "rtsim.notebook"),
    ),
    ("cli", ("rtsim.cli",)),
    ("facade", ("rtsim.__main__", "rtsim._facade")),
)


def module_name(path: Path) -> str:
    rel = path.relative_to(ROOT.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


@cache
def modules() -> dict[str, Path]:
    return {module_name(p): p for p in sorted(ROOT.rglob("*.py"))}


def is_package(mod: str) -> bool:
    return modules()[mod].name == "__init__.py"


def layer(mod: str) -> int:
    if mod == "rtsim":
        return len(LAYERS)  # the facade, above everything
    for i, (_, prefixes) in enumerate(LAYERS):
        if any(mod == p or mod.startswith(p + ".") for p in prefixes):
            return i
    raise AssertionError(f"{mod}: in no layer of LAYERS (add it)")


def _type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _imports(tree: ast.AST, types: bool = False) -> Iterator[ast.Import | ast.ImportFrom]:
    """Every import statement, except those in the body of ``if TYPE_CHECKING:`` (included
    with ``types``)."""
    stack: list[ast.AST] = [tree]
    while stack:
        node = stack.pop()
        if not types and isinstance(node, ast.If) and _type_checking(node.test):
            stack.extend(node.orelse)
            continue
        if isinstance(node, ast.Import | ast.ImportFrom):
            yield node
        stack.extend(ast.iter_child_nodes(node))


@cache
def _tree(mod: str) -> ast.Module:
    return ast.parse(modules()[mod].read_text(encoding="utf-8"))


def _absolute(mod: str, node: ast.ImportFrom) -> str:
    if not node.level:
        return node.module or ""
    base = mod.split(".") if is_package(mod) else mod.split(".")[:-1]
    base = base[: len(base) - node.level + 1]
    return ".".join(base + ([node.module] if node.module else []))


@cache
def defining_module(mod: str, name: str, depth: int = 0) -> str:
    """The module that defines ``name`` as seen from ``mod`` (follows re-exports)."""
    if f"{mod}.{name}" in modules():
        return f"{mod}.{name}"
    if depth > 20:
        return mod
    for node in _imports(_tree(mod)):
        if isinstance(node, ast.ImportFrom):
            src = _absolute(mod, node)
            for alias in node.names:
                if (alias.asname or alias.name) == name and src in modules():
                    return defining_module(src, alias.name, depth + 1)
    return mod


@cache
def edges(mod: str, types: bool = False) -> frozenset[str]:
    """The modules ``mod`` imports (``types``: type-only imports counted too)."""
    out: set[str] = set()
    for node in _imports(_tree(mod), types):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name == "rtsim" or alias.name.startswith("rtsim."):
                    out.add(alias.name)
        else:
            src = _absolute(mod, node)
            if src != "rtsim" and not src.startswith("rtsim."):
                continue
            for alias in node.names:
                out.add(defining_module(src, alias.name) if src in modules() else src)
    out.discard(mod)
    return frozenset(out)


def graph(types: bool = False) -> dict[str, frozenset[str]]:
    return {m: edges(m, types) for m in modules()}


def cycles(g: dict[str, frozenset[str]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(g.get(v, ())):
            if w not in g:
                continue
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(g):
        if v not in index:
            visit(v)
    return out


def _layer_name(mod: str) -> str:
    return LAYERS[min(layer(mod), len(LAYERS) - 1)][0]


def upward(g: dict[str, frozenset[str]]) -> list[str]:
    return sorted(
        f"{m} ({_layer_name(m)}) -> {t} ({_layer_name(t)})"
        for m, ts in g.items()
        if m != "rtsim"
        for t in ts
        if t in g and layer(t) > layer(m)
    )


def test_every_import_resolves_to_a_module() -> None:
    g = graph()
    missing = sorted(f"{m} -> {t}" for m, ts in g.items() for t in ts if t not in g)
    assert missing == []


def test_no_module_imports_the_top_level_package() -> None:
    g = graph()
    assert sorted(m for m, ts in g.items() if "rtsim" in ts) == []


def test_no_import_circles() -> None:
    assert cycles(graph()) == []


def test_no_arrow_runs_up_a_layer() -> None:
    assert upward(graph()) == []


def test_no_import_circles_counting_type_only_imports() -> None:
    """A type imported under ``if TYPE_CHECKING:`` ties two modules as much as a runtime
    import does for a reader: a type that both need lives below both (issue 31)."""
    assert cycles(graph(types=True)) == []
    assert upward(graph(types=True)) == []


def test_the_world_never_imports_the_controller() -> None:
    """Within their shared layer, control sits on the world: the controller's kernels and
    its compiled rollout call the world's (rtsim.control.kernels), never the other way."""
    g = graph(types=True)
    up = sorted(
        f"{m} -> {t}"
        for m, ts in g.items()
        if m.startswith("rtsim.world")
        for t in ts
        if t.startswith("rtsim.control")
    )
    assert up == []
    assert "rtsim.world.kernels" in g["rtsim.control.kernels"]  # (the check sees the arrow)


def test_the_checker_sees_circles_and_upward_arrows() -> None:
    """The checks can fail: a hand-made graph with a circle and an arrow up."""
    g = {"rtsim.model.a": frozenset({"rtsim.sim.b"}), "rtsim.sim.b": frozenset({"rtsim.model.a"})}
    assert cycles(g) == [["rtsim.model.a", "rtsim.sim.b"]]
    assert upward(g) == ["rtsim.model.a (model) -> rtsim.sim.b (world / sim / control)"]
    tree = ast.parse(
        "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    import rtsim.x\n"
        "def f():\n    import rtsim.y\n"
    )
    assert [a.name for n in _imports(tree) if isinstance(n, ast.Import) for a in n.names] == [
        "rtsim.y"
    ]
    names = [a.name for n in _imports(tree, True) if isinstance(n, ast.Import) for a in n.names]
    assert sorted(names) == ["rtsim.x", "rtsim.y"]


if __name__ == "__main__":  # python tests/project/test_import_layers.py: the current findings
    g = graph()
    print("modules:", len(g), "edges:", sum(len(v) for v in g.values()))
    for c in cycles(g):
        print("circle:", " ".join(c))
    for c in cycles(graph(types=True)):
        print("circle (type-only imports counted):", " ".join(c))
    for u in upward(g):
        print("up:", u)
    for m, ts in g.items():
        if "rtsim" in ts:
            print("imports rtsim:", m)
