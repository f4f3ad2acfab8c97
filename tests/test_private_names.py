"""No etsid module imports a private (underscore) name from another etsid package."""

from __future__ import annotations

import ast
import sys
from pathlib import Path

ROOT = Path(__file__).parents[1] / "etsid"


def _package(module: str) -> str:
    """The package (or top-level module) a module belongs to: ``etsid.ident`` for
    ``etsid.ident.run``, ``etsid.table`` for itself."""
    return ".".join(module.split(".")[:2])


def _violations() -> list[str]:
    found = []
    for path in sorted(ROOT.rglob("*.py")):
        rel = path.relative_to(ROOT.parent).with_suffix("")
        parts = rel.parts[:-1] if rel.name == "__init__" else rel.parts
        own = _package(".".join(parts) if rel.name != "__init__" or len(parts) > 1
                       else "etsid.__init__")
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not (isinstance(node, ast.ImportFrom) and node.module
                    and node.module.startswith("etsid")):
                continue
            if _package(node.module) == own:
                continue
            for alias in node.names:
                if alias.name.startswith("_") and not alias.name.startswith("__"):
                    found.append(f"{rel}: from {node.module} import {alias.name}")
    return found


def test_no_private_names_cross_packages() -> None:
    assert _violations() == []


def test_the_check_sees_a_violation(tmp_path, monkeypatch) -> None:
    fake = tmp_path / "etsid"
    (fake / "report").mkdir(parents=True)
    (fake / "report" / "x.py").write_text("from etsid.ident.run import _secret\n"
                                          "from etsid.report.y import _mine\n")
    monkeypatch.setattr(sys.modules[__name__], "ROOT", fake)
    assert _violations() == ["etsid/report/x: from etsid.ident.run import _secret"]
