"""The package layout of ingest holds: import directions and no private names across modules."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ETSID = Path(__file__).parents[2] / "etsid"


def imports(path: Path) -> list[tuple[str, list[str]]]:
    """(module, names) of every ``import`` / ``from … import`` in ``path`` (also in functions)."""
    out = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module:
            out.append((node.module, [a.name for a in node.names]))
        elif isinstance(node, ast.Import):
            out.extend((a.name, []) for a in node.names)
    return out


def sources(*parts: str) -> list[Path]:
    base = ETSID.joinpath(*parts)
    return [base] if base.suffix == ".py" else sorted(base.rglob("*.py"))


def test_sim_imports_nothing_of_ingest() -> None:
    bad = [(p.name, m) for p in sources("sim") for m, _ in imports(p)
           if m.startswith("etsid.ingest")]
    assert bad == []


@pytest.mark.parametrize("module", ["ulog.py", "dataflash.py"])
def test_ulog_and_dataflash_stand_apart_from_mavlink(module: str) -> None:
    assert not [m for m, _ in imports(ETSID / "ingest" / module)
                if m.startswith(("etsid.ingest.mavlink", "etsid.ingest.ros"))]


def test_neutral_modules_import_neither_ingest_nor_sim() -> None:
    for path in sources("frames.py") + sources("pwm.py") + sources("rosmsgs"):
        assert not [m for m, _ in imports(path) if m.startswith(("etsid.ingest", "etsid.sim"))]
