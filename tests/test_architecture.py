"""The package-level import graph: it points one way, and docs/architecture.md shows it."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

# Layers, lowest first: a room may import only rooms on a strictly lower layer.
LAYERS: dict[str, int] = {
    "errors": 0, "jitnote": 0, "blas": 0, "frames": 0, "pwm": 0, "rosmsgs": 0, "cachedir": 0,
    "etsid": 0.5,  # the package's __init__: sets the numba cache folder (cachedir)
    "escape": 0,
    "progress": 0.25,  # the narrator: installs jitnote's compile note
    "files": 0.5, "schemas": 0.5,  # the opener and the schemas: above errors, below the rest
    "table": 1,
    "ets": 2, "ingest": 2, "sim": 2,
    "ident": 3, "fit": 3,
    "report": 4, "gap": 4, "control": 4,
    "batch": 5,
    "cli": 6,
    "__main__": 7,
}


def _load_tool():
    spec = importlib.util.spec_from_file_location("import_graph", ROOT / "docs" / "import_graph.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules["import_graph"] = module
    spec.loader.exec_module(module)
    return module


graph_tool = _load_tool()
GRAPH = graph_tool.graph()


def test_every_room_has_a_layer() -> None:
    missing = sorted(set(GRAPH) - set(LAYERS))
    assert missing == [], f"place {missing} in LAYERS (and in docs/architecture.md)"


@pytest.mark.parametrize("room", sorted(GRAPH))
def test_imports_point_down(room: str) -> None:
    upward = [dst for dst in GRAPH[room] if LAYERS[dst] >= LAYERS[room]]
    assert upward == [], f"{room} imports {upward} on its own or a higher layer"


def test_ets_core_imports_only_errors() -> None:
    assert GRAPH["ets"] <= {"errors", "files"}  # files: the one opener (etsid/files.py)


def test_sim_imports_nothing_of_ingest_or_ident() -> None:
    assert not GRAPH["sim"] & {"ingest", "ident", "report"}


def test_no_private_names_across_packages() -> None:
    assert graph_tool.private_imports() == []


def test_the_private_check_sees_a_violation(tmp_path: Path, monkeypatch) -> None:
    fake = tmp_path / "etsid"
    (fake / "report").mkdir(parents=True)
    (fake / "report" / "x.py").write_text("from etsid.ident.run import _secret\n"
                                          "from etsid.report.y import _mine\n")
    monkeypatch.setattr(graph_tool, "ROOT", tmp_path)
    monkeypatch.setattr(graph_tool, "PACKAGE", fake)
    assert graph_tool.private_imports() == ["etsid/report/x.py: etsid.ident.run._secret"]


def test_architecture_page_shows_the_real_graph() -> None:
    page = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    rendered = graph_tool.render(GRAPH)
    assert rendered in page, (
        "docs/architecture.md is stale: paste the output of `python docs/import_graph.py`")


def test_architecture_page_names_every_package() -> None:
    page = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    rooms = [p.name for p in (ROOT / "etsid").iterdir()
             if (p.is_dir() and (p / "__init__.py").exists()) or p.suffix == ".py"]
    entry = ("__init__.py", "__main__.py")
    missing = [r for r in rooms if f"etsid/{r}" not in page and r not in entry]
    assert missing == []
