"""The shape of the lodkit package: no import circle among its modules, and no module using
another module's private names.

The rule, exactly:

* The graph.  Every ``lodkit/**/*.py`` file is a node, named by its module path
  (``lodkit/__init__.py`` is ``lodkit``, ``lodkit/drivers/edge.py`` is ``lodkit.drivers.edge``).
  Every import statement in it -- at module level or inside a function, class or ``if``:
  the whole syntax tree is walked -- is an edge to the lodkit module it names:
  ``import lodkit.a.b`` and ``from lodkit.a.b import x`` name ``lodkit.a.b``;
  ``from lodkit.a import b`` names ``lodkit.a.b`` when ``b`` is a module or package
  (a ``.py``, ``.pyx`` or package directory), else ``lodkit.a``.  Relative imports are
  resolved against the importing module's package first.  The parent packages Python
  runs before a module (``lodkit/__init__.py`` before ``lodkit.x``) are not edges: the
  package ``__init__`` files only re-export.  Compiled modules (``lodkit._core.*``) are
  leaves.  The graph must have no cycle.
* Private names.  A module may not import a name with a leading underscore from another
  lodkit module (``from lodkit.api import _as_mesh``, ``from .api import _as_mesh``), nor
  read one as an attribute of a lodkit module it imported (``from . import api`` then
  ``api._locked_mask``).  Importing a private *module* is allowed (``lodkit._pipeline``,
  ``lodkit._core.decimate``): the rule is about names.  Dunder names (``__version__``)
  are not private.
"""
from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

from conftest import lodkit_subprocess_env

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "lodkit"


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _sources() -> dict[str, Path]:
    return {_module_name(p): p for p in sorted(PACKAGE.rglob("*.py")) if ".venv" not in p.parts}


def _is_module(name: str) -> bool:
    """True when ``name`` (lodkit.x.y) is a module or package of the source tree."""
    path = ROOT.joinpath(*name.split("."))
    return (path.with_suffix(".py").is_file() or path.with_suffix(".pyx").is_file()
            or (path / "__init__.py").is_file())


def _package_of(module: str, path: Path) -> str:
    return module if path.name == "__init__.py" else module.rpartition(".")[0]


def _resolve(module: str, path: Path, node: ast.ImportFrom) -> str:
    if node.level == 0:
        return node.module or ""
    base = _package_of(module, path).split(".")
    if node.level > 1:
        base = base[:len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def _is_private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _scan(module: str, path: Path):
    """(imported lodkit modules, private-name uses as messages) of one source file."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    edges, problems, aliases = set(), [], {}
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name == "lodkit" or a.name.startswith("lodkit."):
                    edges.add(a.name)
                    aliases[a.asname or a.name.split(".")[0]] = a.name if a.asname else "lodkit"
        elif isinstance(node, ast.ImportFrom):
            target = _resolve(module, path, node)
            if not (target == "lodkit" or target.startswith("lodkit.")):
                continue
            for a in node.names:
                sub = f"{target}.{a.name}"
                if _is_module(sub):
                    edges.add(sub)
                    aliases[a.asname or a.name] = sub
                else:
                    edges.add(target)
                    if _is_private(a.name) and target != module:
                        problems.append(f"{module} (line {node.lineno}) imports {a.name} from {target}")
    for node in ast.walk(tree):
        if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
                and node.value.id in aliases and _is_private(node.attr) and aliases[node.value.id] != module):
            problems.append(f"{module} (line {node.lineno}) uses {aliases[node.value.id]}.{node.attr}")
    edges.discard(module)
    return edges, problems


def _graph():
    sources = _sources()
    graph, problems = {}, []
    for module, path in sources.items():
        edges, found = _scan(module, path)
        graph[module] = sorted(e for e in edges if e in sources)   # compiled modules are leaves
        problems += found
    return graph, problems


def _cycles(graph: dict) -> list[list[str]]:
    """One cycle per strongly connected component of more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]
    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10_000))

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph[v]:
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

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_the_scanner_sees_every_kind_of_import():
    # the rule's own cases, on the real tree: a function-local relative import, a
    # module-level one, a subpackage import and an import of a compiled module
    graph, _ = _graph()
    assert "lodkit.drivers" in graph["lodkit.api"]
    assert "lodkit._pipeline" in graph["lodkit.drivers.edge"]
    assert "lodkit.io" in graph["lodkit.cli"]                 # function-local ``from .io import ...``
    assert "lodkit.metrics.base" in graph["lodkit.metrics.curvature"]     # ``from .base import``
    assert len(graph) >= 30


def test_no_import_cycle():
    graph, _ = _graph()
    cycles = _cycles(graph)
    assert not cycles, "import cycles among lodkit modules: " + "; ".join(" <-> ".join(c) for c in cycles)


def test_no_private_names_across_modules():
    _, problems = _graph()
    assert not problems, "private names used across lodkit modules:\n" + "\n".join(problems)


def test_import_lodkit_stays_light(tmp_path):
    # heavy optional dependencies are imported where they are used, not by ``import lodkit``
    code = ("import sys, lodkit; heavy = [m for m in ('open3d', 'matplotlib', 'dask', 'scipy.spatial') "
            "if m in sys.modules]; print(','.join(heavy))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=lodkit_subprocess_env(),
                         cwd=tmp_path, check=True)
    assert out.stdout.strip() == "", f"import lodkit imports {out.stdout.strip()}"
