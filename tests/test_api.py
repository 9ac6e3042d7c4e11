"""Package boundaries: declared public names exist, and imports follow physics <- datagen <- learn <- experiments."""

import ast
import importlib
import json
import os
import pkgutil
import re
import subprocess
import sys
from pathlib import Path

import pytest

from experiments.cli import COMMANDS

ROOT = Path(__file__).resolve().parents[1]
LAYERS = ["physics", "datagen", "learn", "experiments"]


def _imported_packages(path):
    tree = ast.parse(path.read_text(), str(path))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            yield from (a.name.split(".")[0] for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            yield node.module.split(".")[0]


@pytest.mark.parametrize("layer", LAYERS[:-1])
def test_no_package_imports_a_later_layer(layer):
    later = set(LAYERS[LAYERS.index(layer) + 1:])
    bad = sorted(f"{p.relative_to(ROOT)} imports {pkg}" for p in (ROOT / layer).rglob("*.py")
                 for pkg in _imported_packages(p) if pkg in later)
    assert bad == []


@pytest.mark.parametrize("package", ["physics", "datagen", "learn", "experiments"])
def test_declared_public_names_exist(package):
    mod = importlib.import_module(package)
    assert hasattr(mod, "__all__")
    missing = [n for n in mod.__all__ if not hasattr(mod, n)]
    assert missing == []


# Modules another branch is changing; they declare `__all__` once that work is merged.
WITHOUT_ALL: set = set()


def _public_modules():
    for layer in LAYERS:
        package = importlib.import_module(layer)
        yield layer
        for info in pkgutil.walk_packages(package.__path__, prefix=f"{layer}."):
            if not any(part.startswith("_") for part in info.name.split(".")) and info.name not in WITHOUT_ALL:
                yield info.name


PUBLIC_MODULES = sorted(_public_modules())


def test_every_layer_module_is_walked():
    assert len(PUBLIC_MODULES) >= 70
    assert {"physics.fem", "datagen.pipeline", "learn.pairs.classify", "experiments.cli.cmd_update",
            "experiments.second_sim.fem"} <= set(PUBLIC_MODULES)


@pytest.mark.parametrize("name", PUBLIC_MODULES)
def test_every_public_module_declares_existing_names(name):
    mod = importlib.import_module(name)
    assert isinstance(getattr(mod, "__all__", None), list), f"{name} has no __all__ list"
    assert [n for n in mod.__all__ if not hasattr(mod, n)] == []
    assert len(set(mod.__all__)) == len(mod.__all__)


#: Libraries that take from a tenth of a second to over a second to import (optional ones among them). A module
#: imports them at its head only if every use of the module needs them; otherwise in the functions that use them.
HEAVY = ("torch", "sklearn", "scipy", "matplotlib", "pandas", "pyarrow", "numba", "pyuff", "tqdm", "distributed",
         "pyoma2", "sdypy")
#: The only libraries a command's start-up (its parser, ``--help``) imports.
AT_START_UP = ("numpy", "threadpoolctl")


def _project_modules():
    """Every module of the project: the libraries and every sub-package of ``experiments`` (the command line, the
    studies, the benchmarks, the independent simulator)."""
    yield from (p for layer in LAYERS for p in sorted((ROOT / layer).rglob("*.py")))


def test_imports_inside_functions_are_heavy_libraries_only():
    """Every module of the project imports at its head; an import inside a function
    is of a heavy library (:data:`HEAVY`) or of a project module that imports one, named in its comment
    (``from learn.network.training import train  # torch: the network``)."""
    bad = []
    for path in _project_modules():
        source = path.read_text()
        lines = source.splitlines()
        for fn in ast.walk(ast.parse(source, str(path))):
            if not isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            for node in ast.walk(fn):
                if isinstance(node, ast.Import):
                    names = [a.name for a in node.names]
                elif isinstance(node, ast.ImportFrom) and node.level == 0:
                    names = [node.module]
                else:
                    continue
                comment = lines[node.end_lineno - 1].partition("#")[2]
                heavy = all(n.split(".")[0] in HEAVY for n in names)
                if not (heavy or re.search(rf"\b({'|'.join(HEAVY)})\b", comment)):
                    bad.append(f"{path.relative_to(ROOT)}:{node.lineno} imports {', '.join(names)}")
    assert bad == []


def test_no_command_start_up_imports_a_heavy_library():
    """``beam-damage --help`` imports no command module; a command's parser (its ``--help``) imports its own module
    and no library but :data:`AT_START_UP` (a fresh interpreter builds every command's parser in turn)."""
    code = f"""
import json, sys
from experiments.cli import COMMANDS, build_parser
allowed = {AT_START_UP!r} + ("physics", "datagen", "learn", "experiments")
modules = {{c.module for c in COMMANDS.values()}}
def loaded(before, own=None):
    libraries = {{m.split(".")[0] for m in sys.modules if not m.startswith("_")}} - set(sys.stdlib_module_names)
    return sorted((modules & set(sys.modules)) - before - {{own}}) + sorted(libraries - set(allowed))
build_parser(["--help"])
out = {{"--help": loaded(set())}}
for name, command in COMMANDS.items():
    before = set(sys.modules)
    sub = next(a for a in build_parser([name, "--help"])._actions if a.dest == "command")
    assert len(sub.choices[name]._actions) > 1 and len(sub.choices) == len(COMMANDS)   # its own parser, all listed
    out[name] = loaded(before, command.module)
print(json.dumps(out))
"""
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT,
                          env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout) == {name: [] for name in ["--help", *COMMANDS]}


def _shipped_packages() -> tuple[set, set]:
    """The packages of the project the wheel ships (what setuptools finds with ``pyproject.toml``'s
    ``packages.find``) and those it does not."""
    import tomllib

    from setuptools import find_packages

    find = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"]["find"]
    shipped = set(find_packages(str(ROOT), include=find["include"], exclude=find.get("exclude", ())))
    return shipped, set(find_packages(str(ROOT), include=[f"{layer}*" for layer in LAYERS])) - shipped


def test_the_wheel_imports_no_source_tree_tool():
    """The wheel ships the libraries, the command line and the studies it runs; the benchmarks and the independent
    simulator stay in the source tree, and no shipped module imports them (at its head or in a function)."""
    shipped, tools = _shipped_packages()
    assert {"physics", "datagen", "learn", "experiments", "experiments.cli", "experiments.studies"} <= shipped
    assert tools == {"experiments.benches", "experiments.second_sim"}
    bad = []
    for package in sorted(shipped):
        for path in sorted((ROOT / package.replace(".", "/")).glob("*.py")):
            for node in ast.walk(ast.parse(path.read_text(), str(path))):
                names = ([a.name for a in node.names] if isinstance(node, ast.Import) else
                         [node.module] if isinstance(node, ast.ImportFrom) and node.level == 0 else [])
                bad += [f"{path.relative_to(ROOT)}:{node.lineno} imports {n}" for n in names
                        if any(n == t or n.startswith(f"{t}.") for t in tools)]
    assert bad == []
