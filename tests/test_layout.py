"""The Python package's layout: its modules import one another at the top only, leaf first, with
no cycle (optional third-party packages may still be imported where they are needed)."""

from __future__ import annotations

import ast
from pathlib import Path

import starid

PACKAGE = Path(starid.__file__).resolve().parent


def _own_imports(path: Path) -> tuple[set[str], list[str]]:
    """The starid modules ``path`` imports at module level, and the lines where it imports one
    inside a function or class."""
    tree = ast.parse(path.read_text(), str(path))
    top: set[str] = set()
    nested: list[str] = []

    def names(node: ast.AST) -> set[str]:
        if isinstance(node, ast.ImportFrom) and node.level == 1:
            if node.module:
                return {node.module.split(".")[0]}
            return {a.name for a in node.names}
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("starid."):
            return {(node.module or "").split(".")[1]}
        if isinstance(node, ast.Import):
            return {a.name.split(".")[1] for a in node.names if a.name.startswith("starid.")}
        return set()

    for node in tree.body:
        top |= names(node)
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            for inner in ast.walk(node):
                if names(inner):
                    nested.append(f"{path.name}:{inner.lineno}")
    return top, nested


def _graph() -> tuple[dict[str, set[str]], list[str]]:
    graph: dict[str, set[str]] = {}
    nested: list[str] = []
    for path in sorted(PACKAGE.glob("*.py")):
        top, inner = _own_imports(path)
        graph[path.stem] = {m for m in top if (PACKAGE / f"{m}.py").exists()}
        nested += inner
    return graph, nested


def test_no_module_imports_another_inside_a_function() -> None:
    _, nested = _graph()
    assert nested == [], f"starid modules imported inside functions: {nested}"


def test_the_modules_import_one_another_without_a_cycle() -> None:
    graph, _ = _graph()
    done: set[str] = set()

    def visit(name: str, path: list[str]) -> None:
        if name in path:
            raise AssertionError("import cycle: " + " -> ".join(path[path.index(name):] + [name]))
        if name in done:
            return
        for dep in sorted(graph.get(name, ())):
            visit(dep, path + [name])
        done.add(name)

    for name in sorted(graph):
        visit(name, [])
    assert {"_args", "_identify", "images", "plot"} <= done


def test_the_guard_sees_a_cycle_and_a_nested_import(tmp_path: Path) -> None:
    (tmp_path / "a.py").write_text("from . import b\n\ndef f():\n    from .b import g\n")
    top, nested = _own_imports(tmp_path / "a.py")
    assert top == {"b"} and nested == ["a.py:4"]
