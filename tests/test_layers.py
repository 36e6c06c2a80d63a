"""Code boundaries: no private (underscore) name is imported from another occrl module."""

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "occrl"


def private_imports() -> list[str]:
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("occrl"):
                for alias in node.names:
                    if alias.name.startswith("_") and alias.name != "__version__":
                        found.append(f"{path.relative_to(PACKAGE.parent)}:{node.lineno} imports {alias.name} from {node.module}")
    return found


def test_no_private_names_cross_modules():
    assert private_imports() == []


# Imports only go down these layers: a module may import from a lower level only.
LEVELS = {
    "perception": -1,  # camera perception needs no torch: below envs, which may use it
    "atomic_files": 0,
    "envs": 0,
    "modules": 1,
    "objectives": 2,
    "planners": 2,
    "pretrained": 2,
    "baselines": 3,
    "robot": 3,
    "distributed": 3,
    "training": 4,
    "eval": 4,
    "fingerprints": 5,
    "cli": 5,
    "__init__": 5,
}


def upward_imports() -> list[str]:
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        src = path.relative_to(PACKAGE).parts[0].removesuffix(".py")
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("occrl."):
                dst = node.module.split(".")[1]
                if dst != src and LEVELS[dst] >= LEVELS[src]:
                    found.append(f"{path.relative_to(PACKAGE.parent)}:{node.lineno} ({src}) imports {node.module} ({dst})")
    return found


def test_every_package_has_a_level():
    packages = {p.relative_to(PACKAGE).parts[0].removesuffix(".py") for p in PACKAGE.rglob("*.py")}
    assert packages <= set(LEVELS), packages - set(LEVELS)


def test_imports_only_go_down():
    assert upward_imports() == []
