"""Print etsid's package-level import graph, read from the code (run from the repo root).

    python docs/import_graph.py            # the graph, one line per package
    python docs/import_graph.py --private  # cross-package imports of underscore names
    python docs/import_graph.py --update   # rewrite the graph block in docs/architecture.md

A "package" is a top-level room of etsid: ``etsid/ingest/ros/fast/x.py`` belongs to
``ingest``, ``etsid/table.py`` to ``table``. Imports inside functions count (lazy
imports are still dependencies). ``tests/test_architecture.py`` checks that
``docs/architecture.md`` shows exactly this graph.
"""

from __future__ import annotations

import ast
import sys
from collections.abc import Iterator
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "etsid"


def room_of(module: str) -> str:
    """The top-level room of a dotted module name inside etsid (``etsid.a.b`` → ``a``)."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "etsid"


def module_name(path: Path) -> str:
    """Dotted name of a source file under ``etsid/``."""
    rel = path.relative_to(ROOT).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def imports_of(path: Path) -> Iterator[tuple[str, list[str]]]:
    """Every ``etsid`` module imported by a file, with the names taken from it."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    here = module_name(path).split(".")
    is_pkg = path.name == "__init__.py"
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("etsid"):
                    yield alias.name, []
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = here if is_pkg else here[:-1]
                base = base[: len(base) - (node.level - 1)]
                target = ".".join([*base, *([node.module] if node.module else [])])
            else:
                target = node.module or ""
            if target == "etsid":  # ``from etsid import files``: the module files
                for alias in node.names:
                    if (PACKAGE / alias.name).is_dir() or (PACKAGE / f"{alias.name}.py").is_file():
                        yield f"etsid.{alias.name}", []
            elif target.startswith("etsid"):
                yield target, [a.name for a in node.names]


def graph() -> dict[str, set[str]]:
    """Room → rooms it imports (itself and ``etsid``'s own ``__init__`` left out)."""
    edges: dict[str, set[str]] = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        src = room_of(module_name(path))
        edges.setdefault(src, set())
        for target, _ in imports_of(path):
            dst = room_of(target)
            if dst not in (src, "etsid"):
                edges[src].add(dst)
    return edges


def private_imports() -> list[str]:
    """Cross-room imports of underscore names, as ``file: module.name`` lines."""
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        src = room_of(module_name(path))
        for target, names in imports_of(path):
            if room_of(target) == src:
                continue
            private = [n for n in names if n.startswith("_") and not n.startswith("__")]
            private += [p for p in target.split(".") if p.startswith("_") and p != "__init__"]
            found += [f"{path.relative_to(ROOT)}: {target}.{n}" for n in private]
    return found


def render(edges: dict[str, set[str]]) -> str:
    """One line per room: ``room → a, b`` (``room → (nothing)`` for leaves)."""
    width = max(len(k) for k in edges)
    lines = []
    for room in sorted(edges):
        deps = ", ".join(sorted(edges[room])) or "(nothing of etsid)"
        lines.append(f"{room:<{width}} → {deps}")
    return "\n".join(lines)


def update_page(page: Path) -> None:
    """Replace the first fenced block after the "import graph" heading with the graph."""
    text = page.read_text(encoding="utf-8")
    head = text.index("## The import graph")
    start = text.index("```\n", head) + 4
    end = text.index("```", start)
    page.write_text(text[:start] + render(graph()) + "\n" + text[end:], encoding="utf-8")


def main(argv: list[str]) -> int:
    if "--update" in argv:
        update_page(ROOT / "docs" / "architecture.md")
        return 0
    if "--private" in argv:
        found = private_imports()
        print("\n".join(found) if found else "no cross-package private imports")
        return 1 if found else 0
    print(render(graph()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
