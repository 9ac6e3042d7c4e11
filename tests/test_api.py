"""Package boundaries: declared public names exist, and imports follow physics <- datagen <- learn <- experiments."""

import ast
import importlib
from pathlib import Path

import pytest

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


@pytest.mark.parametrize("package", ["physics", "learn", "experiments"])
def test_declared_public_names_exist(package):
    mod = importlib.import_module(package)
    assert hasattr(mod, "__all__")
    missing = [n for n in mod.__all__ if not hasattr(mod, n)]
    assert missing == []
