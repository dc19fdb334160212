"""The layout: the Python package's modules import one another at the top only, leaf first, with
no cycle (optional third-party packages may still be imported where they are needed); the Rust
core's modules use one another without a cycle, and none but tests uses the simulator."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import starid

PACKAGE = Path(starid.__file__).resolve().parent
RUST_CORE = Path(__file__).resolve().parents[1] / "rust" / "starid-core" / "src"


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


def _leaf_first(graph: dict[str, set[str]]) -> set[str]:
    """Every module of ``graph`` (module → the modules it uses), visited leaf first; an
    AssertionError naming the cycle where there is one."""
    done: set[str] = set()

    def visit(name: str, path: list[str]) -> None:
        if name in path:
            raise AssertionError("cycle: " + " -> ".join(path[path.index(name):] + [name]))
        if name in done:
            return
        for dep in sorted(graph.get(name, ())):
            visit(dep, path + [name])
        done.add(name)

    for name in sorted(graph):
        visit(name, [])
    return done


def test_the_modules_import_one_another_without_a_cycle() -> None:
    graph, _ = _graph()
    assert {"_args", "_identify", "images", "plot"} <= _leaf_first(graph)


def _rust_graph(src: Path) -> dict[str, set[str]]:
    """The Rust crate's top-level modules (``src/x.rs`` or ``src/x/``), each with the others its
    production code names (``crate::other``): comments, test modules (``#[cfg(test)]`` to the end
    of a file) and ``tests.rs`` files aside."""
    graph: dict[str, set[str]] = {}
    for path in sorted(src.rglob("*.rs")):
        if path.name == "tests.rs":
            continue
        module = path.relative_to(src).parts[0].removesuffix(".rs")
        code = re.sub(r"//[^\n]*", "", path.read_text().split("#[cfg(test)]")[0])
        graph.setdefault(module, set()).update(m for m in re.findall(r"\bcrate::([a-z_]+)", code) if m != module)
    return graph


def test_the_rust_core_modules_use_one_another_without_a_cycle_and_not_the_simulator() -> None:
    graph = _rust_graph(RUST_CORE)
    assert {"identify", "catalog", "kvector", "tracking", "simulate"} <= _leaf_first(graph)
    assert [m for m, uses in graph.items() if "simulate" in uses] == []


def test_the_rust_guard_sees_a_cycle(tmp_path: Path) -> None:
    (tmp_path / "a").mkdir()
    (tmp_path / "a" / "mod.rs").write_text("use crate::b::x; // crate::c\n#[cfg(test)]\nuse crate::c::y;\n")
    (tmp_path / "b.rs").write_text("fn f() { crate::a::g() }\n")
    (tmp_path / "c.rs").write_text("")
    graph = _rust_graph(tmp_path)
    assert graph == {"a": {"b"}, "b": {"a"}, "c": set()}
    try:
        _leaf_first(graph)
    except AssertionError as e:
        assert "a -> b -> a" in str(e)
    else:
        raise AssertionError("the cycle a -> b -> a was not seen")


def test_the_guard_sees_a_cycle_and_a_nested_import(tmp_path: Path) -> None:
    (tmp_path / "a.py").write_text("from . import b\n\ndef f():\n    from .b import g\n")
    top, nested = _own_imports(tmp_path / "a.py")
    assert top == {"b"} and nested == ["a.py:4"]
