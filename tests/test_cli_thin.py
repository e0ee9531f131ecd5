"""The command line is a thin layer over the Python API (fe_impact.api).

Each module of ``fe_impact/cli`` parses options, calls the API and prints what it
returns: the pipelines (meshing, solving, calibrating, the switching model) live
in the library, where a script reaches them too. Checked on the source, with
:mod:`ast`: every ``fe_impact`` module a CLI module imports (at the top or inside
a function) is the API or one of the few leaves the CLI needs to report
(errors, defaults, interrupts, files); no numerical library is imported; no
private name crosses modules; and each module stays small.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

CLI = Path(__file__).resolve().parents[1] / "fe_impact" / "cli"

#: The fe_impact modules a CLI module may import: the API (and the package, which
#: re-exports it), the error classes it prints, the option defaults, the signal
#: handling, output-folder checks and JSON writing, and the other CLI modules.
ALLOWED = ("fe_impact", "fe_impact.api", "fe_impact.errors", "fe_impact.defaults",
           "fe_impact.interrupts", "fe_impact.runtime", "fe_impact.atomic",
           "fe_impact.output.files")
#: Libraries that do numerical work: a CLI module that needs one holds a pipeline.
NUMERICAL = ("numpy", "scipy", "skfem", "meshio", "gmsh", "numba", "dask", "distributed",
             "pyvista", "matplotlib")
#: Lines of a CLI module at most: the largest is the calibrate command's option
#: declarations and help texts (main.py, some 300 lines).
MAX_LINES = 400

MODULES = sorted(CLI.glob("*.py"))


def imports(tree: ast.AST) -> list[tuple[str, list[str], int]]:
    """Every import of the module: (module, names imported from it, line)."""
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(alias.name, [], node.lineno) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found.append((node.module, [a.name for a in node.names], node.lineno))
    return found


@pytest.mark.parametrize("path", MODULES, ids=lambda p: p.name)
def test_cli_module_imports_the_library_only_through_the_api(path):
    tree = ast.parse(path.read_text(encoding="utf-8"))
    wrong = []
    for module, names, line in imports(tree):
        top = module.split(".")[0]
        if top in NUMERICAL:
            wrong.append(f"line {line}: imports {module} (numerical work belongs in the library)")
        if top == "fe_impact" and not (module in ALLOWED or module.startswith("fe_impact.cli")):
            wrong.append(f"line {line}: imports {module}; call it through fe_impact.api")
        private = [n for n in names if n.startswith("_") and n != "__version__"]
        if top == "fe_impact" and private:
            wrong.append(f"line {line}: imports private {private} from {module}")
    assert not wrong, f"{path.name}:\n" + "\n".join(wrong)


@pytest.mark.parametrize("path", MODULES, ids=lambda p: p.name)
def test_cli_module_stays_small(path):
    lines = len(path.read_text(encoding="utf-8").splitlines())
    assert lines <= MAX_LINES, f"{path.name}: {lines} lines (at most {MAX_LINES})"


def test_the_checks_catch_a_pipeline_import():
    # the checks themselves: a handler importing the sweep or numpy is caught
    source = ("def run(args):\n"
              "    import numpy as np\n"
              "    from fe_impact.calibration.execution import calibrate\n")
    found = [m for m, _, _ in imports(ast.parse(source))]
    assert found == ["numpy", "fe_impact.calibration.execution"]
    assert not any(m in ALLOWED for m in found)


def test_the_api_is_the_package_namespace():
    # what the CLI calls is importable from the package itself, without the
    # numerical modules (importing fe_impact stays cheap)
    import subprocess
    import sys

    code = ("import sys, fe_impact\n"
            "heavy = [m for m in ('numpy', 'scipy', 'skfem', 'gmsh', 'numba', 'distributed')\n"
            "         if m in sys.modules]\n"
            "assert not heavy, heavy\n"
            "assert fe_impact.calibrate is fe_impact.api.calibrate\n"
            "assert set(fe_impact.__all__) - {'__version__'} <= set(fe_impact.api.__all__)\n")
    subprocess.run([sys.executable, "-c", code], check=True)
