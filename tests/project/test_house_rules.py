"""House rules of the code, counted (issue 31, item 5).

- An rtsim module imports the rtsim modules it uses at its top, so that its first screen
  shows them. An import inside a function is allowed only with a stated reason: a
  ``# lazy: <reason>`` comment on the import's first line (a heavy third-party dependency
  such as numpy, pandas or matplotlib that the importing module does not otherwise load, the
  command line's start-up time, a module the plug-in machinery loads by name, ...). At most
  `MAX_LAZY` such imports remain.
- No function of `MAX_FUNCTION_LINES` lines or more, except those in `LONG_FUNCTIONS`.
- A module docstring says what the module is and which page of ``docs/`` to read: at most
  `MAX_DOCSTRING_LINES` lines. A specification belongs in the documentation.
- One meaning per name: ``FollowerModel`` is the world's follower model only, and
  ``POLICIES`` (once schedulers in ``rtsim.sim``, adjustment policies in ``rtsim.control``)
  is gone for ``SCHEDULERS`` and ``ADJUSTMENT_POLICIES``.
"""

from __future__ import annotations

import ast
import re
from collections.abc import Iterator
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2] / "rtsim"

#: The most function-level rtsim→rtsim imports, with a reason or not (issue 31: at most 80).
MAX_LAZY = 80
#: The marker of a function-level import's reason, on the import's first line.
LAZY = re.compile(r"#\s*lazy:\s*\S")

#: A function is shorter than this many lines (its first decorator or ``def`` to its end).
MAX_FUNCTION_LINES = 150
#: The functions allowed to be longer, with the reason.
#: (None today: the CPU's dispatcher, once one generator of 357 lines, is in rooms, its
#: inline top-task path in rtsim/sim/inline.py: docs/performance.md has what that cost.)
LONG_FUNCTIONS: dict[str, str] = {}

#: A module docstring spans at most this many lines, its quotes included.
MAX_DOCSTRING_LINES = 30


def _python_files() -> list[Path]:
    return sorted(ROOT.rglob("*.py"))


def _module(path: Path) -> str:
    parts = list(path.relative_to(ROOT.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _targets(path: Path, node: ast.Import | ast.ImportFrom) -> list[str]:
    """The absolute module names an import statement names."""
    if isinstance(node, ast.Import):
        return [a.name for a in node.names]
    if not node.level:
        return [node.module or ""]
    base = _module(path).split(".")
    if path.name != "__init__.py":
        base = base[:-1]
    base = base[: len(base) - node.level + 1]
    return [".".join(base + ([node.module] if node.module else []))]


def function_imports(path: Path, source: str) -> Iterator[tuple[int, bool]]:
    """(line, has a reason) of each import of an rtsim module inside a function of the
    module ``source`` (the text of ``path``)."""
    lines = source.splitlines()

    def walk(node: ast.AST, inside: bool) -> Iterator[tuple[int, bool]]:
        for child in ast.iter_child_nodes(node):
            if inside and isinstance(child, ast.Import | ast.ImportFrom):
                if any(t == "rtsim" or t.startswith("rtsim.") for t in _targets(path, child)):
                    yield child.lineno, bool(LAZY.search(lines[child.lineno - 1]))
            is_function = isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef)
            yield from walk(child, inside or is_function)

    yield from walk(ast.parse(source), False)


def lazy_imports() -> tuple[list[str], list[str]]:
    """The function-level rtsim imports: (with a reason, without), as ``file:line``."""
    given: list[str] = []
    missing: list[str] = []
    for path in _python_files():
        rel = path.relative_to(ROOT.parent).as_posix()
        for line, reason in function_imports(path, path.read_text(encoding="utf-8")):
            (given if reason else missing).append(f"{rel}:{line}")
    return given, missing


def function_lengths(tree: ast.AST, rel: str) -> Iterator[tuple[str, int]]:
    """(``rel:Class.function``, its length in lines from its first decorator or ``def`` to
    its last line) of every function in ``tree``, nested ones too."""

    def walk(node: ast.AST, prefix: str) -> Iterator[tuple[str, int]]:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
                name = f"{prefix}{child.name}"
                if not isinstance(child, ast.ClassDef):
                    start = min([child.lineno] + [d.lineno for d in child.decorator_list])
                    yield f"{rel}:{name}", (child.end_lineno or child.lineno) - start + 1
                yield from walk(child, name + ".")
            else:
                yield from walk(child, prefix)

    yield from walk(tree, "")


def long_functions(min_lines: int = MAX_FUNCTION_LINES) -> dict[str, int]:
    """``file:Class.function`` → its length in lines, for every function of rtsim of
    ``min_lines`` lines or more."""
    out: dict[str, int] = {}
    for path in _python_files():
        rel = path.relative_to(ROOT.parent).as_posix()
        tree = ast.parse(path.read_text(encoding="utf-8"))
        out.update((name, n) for name, n in function_lengths(tree, rel) if n >= min_lines)
    return out


def docstring_lines(source: str) -> int:
    """The lines the module docstring of ``source`` spans, quotes included (0: none)."""
    body = ast.parse(source).body
    first = body[0] if body else None
    if not (
        isinstance(first, ast.Expr)
        and isinstance(first.value, ast.Constant)
        and isinstance(first.value.value, str)
    ):
        return 0
    return (first.end_lineno or first.lineno) - first.lineno + 1


def long_docstrings(max_lines: int = MAX_DOCSTRING_LINES) -> dict[str, int]:
    """``file`` → its module docstring's lines, for every rtsim module above ``max_lines``."""
    out = {}
    for path in _python_files():
        n = docstring_lines(path.read_text(encoding="utf-8"))
        if n > max_lines:
            out[path.relative_to(ROOT.parent).as_posix()] = n
    return out


def definitions(name: str) -> list[str]:
    """The rtsim files that define ``name`` at module level (a class, a function or an
    assignment)."""
    out = []
    for path in _python_files():
        for node in ast.parse(path.read_text(encoding="utf-8")).body:
            if isinstance(node, ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
                bound = [node.name]
            elif isinstance(node, ast.Assign | ast.AnnAssign):
                targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                bound = [t.id for t in targets if isinstance(t, ast.Name)]
            else:
                continue
            if name in bound:
                out.append(path.relative_to(ROOT.parent).as_posix())
    return out


def test_one_meaning_per_name() -> None:
    assert definitions("FollowerModel") == ["rtsim/world/formation.py"]
    assert definitions("POLICIES") == []
    assert definitions("SCHEDULERS") == ["rtsim/sim/policy.py"]
    assert definitions("ADJUSTMENT_POLICIES") == ["rtsim/control/policy.py"]


def test_function_level_imports_state_a_reason() -> None:
    """Every rtsim import inside a function says why it is not at the module's top."""
    _, missing = lazy_imports()
    assert missing == [], f"{len(missing)} function-level imports without '# lazy: <reason>'"


def test_few_function_level_imports_remain() -> None:
    given, missing = lazy_imports()
    assert len(given) + len(missing) <= MAX_LAZY, len(given) + len(missing)


def test_no_function_of_150_lines_or_more() -> None:
    found = long_functions()
    assert sorted(set(found) - set(LONG_FUNCTIONS)) == [], found
    # the allow-list names functions that exist (a split one leaves the list)
    assert all(f in long_functions(1) for f in LONG_FUNCTIONS), sorted(LONG_FUNCTIONS)


def test_module_docstrings_are_summaries() -> None:
    """A specification in a module docstring goes to its page under docs/, leaving a summary."""
    assert long_docstrings() == {}


def test_the_counters_see_what_they_count(tmp_path: Path) -> None:
    """The checks can fail: a hand-made module with each kind of import and a long function."""
    source = (
        "import rtsim.errors\n"
        "def f():\n"
        "    from rtsim.io import atomic\n"
        "    from rtsim.io import limits  # lazy: a reason\n"
        "    import numpy\n"
        "    from . import work\n"
        "    if True:\n"
        "        import rtsim.model\n" + "    x = 1\n" * 150
    )
    path = ROOT / "io" / "example.py"  # (not written: only its name places the relative import)
    assert list(function_imports(path, source)) == [(3, False), (4, True), (6, False), (8, False)]
    assert dict(function_lengths(ast.parse(source), "x.py")) == {"x.py:f": 157}
    assert docstring_lines('"""One."""\nx = 1\n') == 1
    assert docstring_lines('"""One\n\ntwo.\n"""\n') == 4
    assert docstring_lines("x = 1\n") == docstring_lines("") == 0
    nested = "class A:\n    @staticmethod\n    def g():\n        def h():\n            pass\n"
    assert dict(function_lengths(ast.parse(nested), "x.py")) == {"x.py:A.g": 4, "x.py:A.g.h": 2}


if __name__ == "__main__":  # python tests/project/test_house_rules.py: the current findings
    given, missing = lazy_imports()
    print(f"function-level rtsim imports: {len(given)} with a reason, {len(missing)} without")
    for where in missing:
        print("  no reason:", where)
    for name, n in sorted(long_docstrings(0).items(), key=lambda kv: -kv[1])[:10]:
        print(f"{n:5d} {name} (module docstring)")
    for name, n in sorted(long_functions().items(), key=lambda kv: -kv[1]):
        print(f"{n:5d} {name}{'  (allowed)' if name in LONG_FUNCTIONS else ''}")
