"""The package's shape: imports point downstream only, and no private name crosses a module.

The data flow is gear set -> tooth surfaces -> mesh -> assembly -> contact ->
time integration -> calibration -> lumped model -> results, with the writers,
reports, the API and the commands as leaves (docs/architecture.md). Two checks
hold it, both reading every import statement, those inside functions included
(a lazy import is still a dependency):

- the import-linter contracts of pyproject.toml ``[tool.importlinter]``: the
  stages as layers, and the numerical modules barred from the writers, reports,
  the API and the commands;
- an import graph built here from the syntax trees, which must have no cycle
  between modules, within a package as well as across (the layers contract
  looks only across its layers).
"""

from __future__ import annotations

import ast
import functools
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "fe_impact"


def _module_name(path: Path) -> str:
    if not path.is_relative_to(ROOT):
        return path.stem
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {_module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def _type_checking_nodes(tree: ast.AST) -> set[int]:
    """ids of the nodes under ``if TYPE_CHECKING:`` (annotations only, never run)."""
    inside: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            inside.update(id(n) for n in ast.walk(node))
    return inside


def _imports(path: Path) -> Iterator[tuple[ast.ImportFrom | ast.Import, str, str | None]]:
    """Every import statement of ``path`` that runs (module level or in a function):
    the node, the module it names (relative imports resolved) and, for ``from m
    import x``, the name ``x``."""
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    skip = _type_checking_nodes(tree)
    here = _module_name(path)
    package = here if path.name == "__init__.py" else here.rpartition(".")[0]
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node, alias.name, None
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[:len(package.split(".")) - node.level + 1]
                base = ".".join([*anchor, *([node.module] if node.module else [])])
            for alias in node.names:
                yield node, base, alias.name


@functools.cache
def _graph() -> dict[str, set[str]]:
    """Module -> the package modules it imports (``from p import m`` of a submodule
    counts as importing ``p.m``)."""
    graph: dict[str, set[str]] = {m: set() for m in MODULES}
    for module, path in MODULES.items():
        for _, base, name in _imports(path):
            target = f"{base}.{name}" if name and f"{base}.{name}" in MODULES else base
            if target in MODULES and target != module:
                graph[module].add(target)
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one node (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def _packages(graph: dict[str, set[str]], depth: int = 2) -> dict[str, set[str]]:
    """The graph between ``fe_impact.<package>`` (and top-level modules)."""
    def head(m: str) -> str:
        return ".".join(m.split(".")[:depth])

    out: dict[str, set[str]] = {}
    for a, targets in graph.items():
        out.setdefault(head(a), set())
        for b in targets:
            out.setdefault(head(b), set())
            if head(a) != head(b):
                out[head(a)].add(head(b))
    return out


def test_the_graph_sees_function_level_imports():
    # the check is only as good as the graph: a lazy import inside a function must
    # be an edge (calibration.planning imports the gear kinematics in functions)
    source = (PACKAGE / "calibration" / "planning.py").read_text()
    assert "    from fe_impact.gears.kinematics import" in source
    assert "fe_impact.gears.kinematics" in _graph()["fe_impact.calibration.planning"]


def test_no_module_imports_one_that_imports_it_back():
    assert _cycles(_graph()) == []


def test_no_package_imports_one_that_imports_it_back():
    assert _cycles(_packages(_graph())) == []


def test_the_import_contracts_hold():
    # pyproject.toml [tool.importlinter]: the data-flow layers and the leaves
    lint = Path(sys.executable).with_name("lint-imports")
    if not lint.exists():
        pytest.skip("import-linter is not installed (the test extra)")
    run = subprocess.run([str(lint), str(ROOT / "pyproject.toml")], cwd=ROOT,
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stdout[-4000:] + run.stderr[-2000:]


def _private_imports(path: Path) -> Iterator[str]:
    """``from fe_impact.m import _name`` of a private name of another module. A module
    whose name starts with an underscore is its package's: its siblings may import it
    (``switching.simulation`` imports ``switching._kernel``), nobody else."""
    here = _module_name(path) if path.is_relative_to(PACKAGE) else ""
    for node, base, name in _imports(path):
        if not base.startswith("fe_impact"):
            continue
        parts = base.split(".") + ([name] if name else [])
        for i, part in enumerate(parts):
            if not part.startswith("_") or part.startswith("__"):
                continue
            owner = ".".join(parts[:i])             # the package or module it belongs to
            is_module = ".".join(parts[:i + 1]) in MODULES
            if is_module and (here == owner or here.startswith(owner + ".")):
                continue
            where = path.relative_to(ROOT) if path.is_relative_to(ROOT) else path
            yield f"{where}:{node.lineno}: {'.'.join(parts[:i + 1])}"


def test_no_private_name_is_imported_across_modules():
    # The package, the validation studies and the examples use public names only
    # (the tests may reach into a module's internals: they test them).
    files = [p for folder in ("fe_impact", "validation", "examples")
             for p in sorted((ROOT / folder).rglob("*.py"))]
    found = [hit for path in files for hit in _private_imports(path)]
    assert found == []


def test_the_private_name_check_sees_a_private_import(tmp_path):
    # the check must be able to fail: a private name of another module, and a
    # package-private module imported from outside its package
    bad = tmp_path / "probe.py"
    bad.write_text("def f():\n    from fe_impact.physics.hertz import _series\n"
                   "    from fe_impact.switching import _kernel\n"
                   "    from fe_impact.physics.hertz import impact\n")
    hits = list(_private_imports(bad))
    assert [h.rsplit(": ", 1)[1] for h in hits] == ["fe_impact.physics.hertz._series",
                                                    "fe_impact.switching._kernel"]


def test_the_seed_load_written_below_the_lumped_model_is_the_presets_largest():
    # the mesh cycle's nominal force is taken at the seed's largest load; the
    # calibration may not import the switching presets, so the load is written in
    # fe_impact.defaults: it must be the largest load the preset schedules carry
    from fe_impact.defaults import SEED_LOAD_TORQUE
    from fe_impact.switching.presets import seed_load_torque

    assert seed_load_torque() == SEED_LOAD_TORQUE


def test_resume_keys_survive_the_split_of_the_sweep(monkeypatch):
    # The resume key of an impact case, with the version, the mesh format and the
    # schema held fixed, as the calibration sweep computed it before it was split
    # into planning, measurement and execution (values computed by that module):
    # a refactor that changes them makes every stored result be computed again.
    from fe_impact.calibration import planning
    from fe_impact.meshing import toothpair

    monkeypatch.setattr(planning, "__version__", "0.0.0")
    monkeypatch.setattr(planning, "SCHEMA", "fe-impact/calibration/2")
    monkeypatch.setattr(toothpair, "MESH_FORMAT", 1)
    mesh = planning.ImpactCase(2, 68, "mesh", 0.0387, 300.0)
    switch = planning.ImpactCase(3, 80, "switch", 0.01, 1000.0, "kinematic", 2.5)
    assert planning.case_hash(mesh, planning.Settings(), "gear set") == "b8d96d50ec95c957"
    assert planning.case_hash(switch, planning.Settings(level="coarse", order=1, gap=1e-6),
                              "gear set") == "d83d4bf920563721"
