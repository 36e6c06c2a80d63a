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
