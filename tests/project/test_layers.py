"""The package's floors (docs/architecture.md, "Layers"): a module may import only from its own
package or a lower floor; the ground floor ``core`` imports nothing else of the package; the top
level (``__init__``, the Python API) imports the floors inside functions only; the library never
imports the dataset tools or the CLI; no two modules import each other, directly or
round a longer loop, inside a package or across. Imports inside functions count too."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PKG = ROOT / "src" / "inpaint360gs"

# floor of every sub-package of inpaint360gs (the order of docs/architecture.md)
FLOORS = {
    "core": 0,
    "io": 1,
    "render": 2,
    "metrics": 2,
    "gs": 3,
    "segment": 4,
    "associate": 5,
    "distill": 6,
    "remove": 7,
    "views": 8,
    "inpaint": 9,
    "evaluate": 10,
    "report": 10,
    "pipeline": 11,
    "viewer": 12,
    "cli": 13,
}


def _package_of(module: str) -> str | None:
    parts = module.split(".")
    if parts[0] != "inpaint360gs":
        return None
    return parts[1] if len(parts) > 1 else ""


def _imports(path: Path) -> list[tuple[int, str]]:
    tree = ast.parse(path.read_text(), filename=str(path))
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            out += [(node.lineno, node.module)] + [(node.lineno, f"{node.module}.{a.name}") for a in node.names if node.module == "inpaint360gs"]
    return out


def _eager_import_lines(path: Path) -> set[int]:
    """Lines of the imports that run when the module is imported (not inside a function)."""
    lines, todo = set(), list(ast.parse(path.read_text(), filename=str(path)).body)
    while todo:
        node = todo.pop()
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            lines.add(node.lineno)
        elif not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            todo += list(ast.iter_child_nodes(node))
    return lines


def _modules():
    for p in sorted(PKG.rglob("*.py")):
        rel = p.relative_to(PKG)
        yield p, (rel.parts[0] if len(rel.parts) > 1 else "")


def test_every_package_has_a_floor():
    packages = {pkg for _, pkg in _modules() if pkg}
    assert packages <= set(FLOORS), f"add {sorted(packages - set(FLOORS))} to FLOORS and to docs/architecture.md"


@pytest.mark.parametrize("path, pkg", list(_modules()), ids=lambda x: str(x.relative_to(PKG)) if isinstance(x, Path) else None)
def test_imports_go_down_only(path: Path, pkg: str):
    bad = []
    eager = _eager_import_lines(path)
    for line, mod in _imports(path):
        if mod.split(".")[0] == "dataset_tools":
            bad.append(f"line {line}: {mod} (the library must not import the dataset tools)")
            continue
        target = _package_of(mod)
        if target is None or target == pkg:
            continue
        if pkg == "":  # top-level modules (__init__): the API's floors on first use only, never the CLI
            if line in eager or target == "cli":
                bad.append(f"line {line}: {mod} (the top level imports the package inside functions only, and never the CLI)")
            continue
        if target == "" or target not in FLOORS:
            continue  # `import inpaint360gs` itself (version), or an unknown name the test above reports
        if FLOORS[target] >= FLOORS[pkg]:
            bad.append(f"line {line}: {mod} (floor {FLOORS[target]} >= {pkg}'s {FLOORS[pkg]})")
    assert not bad, f"{path.relative_to(ROOT)} imports from its own floor or above:\n" + "\n".join(bad)


def test_the_layer_check_catches_an_upward_import(tmp_path):
    """The check itself: a render module importing gs is reported."""
    p = tmp_path / "x.py"
    p.write_text("def f():\n    from inpaint360gs.gs.trainer import train_stage\n")
    (line, mod), *_ = _imports(p)
    assert (line, _package_of(mod)) == (2, "gs") and FLOORS["gs"] > FLOORS["render"]


def _module_name(path: Path, pkg_dir: Path) -> str:
    parts = list(path.relative_to(pkg_dir.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _module_graph(pkg_dir: Path) -> dict[str, set[str]]:
    """Module -> the modules of the package it imports (``from a import b`` counts as ``a.b`` where
    that is a module, else as ``a``; relative imports resolved; a package is its ``__init__``)."""
    paths = {_module_name(p, pkg_dir): p for p in sorted(pkg_dir.rglob("*.py"))}
    graph = {}
    for name, path in paths.items():
        here = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
        found = set()
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            if isinstance(node, ast.Import):
                found |= {a.name for a in node.names}
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    base = ".".join(here[: len(here) - node.level + 1] + ([node.module] if node.module else []))
                found |= {f"{base}.{a.name}" if f"{base}.{a.name}" in paths else base for a in node.names}
        graph[name] = {m for m in found if m in paths and m != name}
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The import loops of ``graph``: one path per strongly connected set of two or more modules."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            members = stack[stack.index(v) :]
            del stack[stack.index(v) :]
            if len(members) > 1:
                found.append(sorted(members))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_no_import_cycles():
    loops = _cycles(_module_graph(PKG))
    assert not loops, "modules that import each other (directly or round a loop):\n" + "\n".join(" <-> ".join(c) for c in loops)


def test_the_cycle_check_catches_a_loop_inside_a_package(tmp_path):
    """The check itself: a -> b lazily, b -> a at the top (relative), c outside the loop."""
    pkg = tmp_path / "p"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "sub" / "__init__.py").write_text("")
    (pkg / "sub" / "a.py").write_text("def f():\n    from p.sub import b\n")
    (pkg / "sub" / "b.py").write_text("from .a import f\nfrom p.sub import c\n")
    (pkg / "sub" / "c.py").write_text("")
    assert _cycles(_module_graph(pkg)) == [["p.sub.a", "p.sub.b"]]
