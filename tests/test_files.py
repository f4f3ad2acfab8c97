"""The one opener (etsid/files.py): every file etsid reads goes through it, and it refuses
what would never end or never fit; the one escaping path (etsid/escape.py)."""

from __future__ import annotations

import ast
import os
import threading
from pathlib import Path

import pytest

from etsid import escape, files
from etsid.errors import EtsidError, SimError

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "etsid"

READ_CALLS = {"read_text", "read_bytes", "read_parquet", "read_csv", "read_table",
              "read_metadata", "ParquetFile", "read_json", "read_feather", "read_excel"}
"""Attribute calls that read a file by path (pandas, pyarrow, pathlib)."""
LOADERS = {("json", "load"), ("tomllib", "load"), ("pickle", "load"), ("yaml", "load")}

COPIES = {"copy", "copy2", "copyfile", "copytree"}
"""shutil calls that read a file by path (copyfileobj reads an open handle)."""

ALLOWED = {
    # module: why it may open a file itself
    "etsid/files.py": "the opener",
    "etsid/batch/worker.py": "its own process's /proc/self/status and statm (memory of the "
                             "worker, not an input)",
    "etsid/progress.py": "its own process's /proc/self/stat (when it started), not an input",
    "etsid/rosmsgs/__init__.py": "message definitions shipped inside the package "
                                 "(importlib.resources), not user input",
    "etsid/cachedir.py": "the package's own source files, hashed for the compiled-kernel "
                         "cache's key inside `import etsid`, not user input",
}


def _mode(call: ast.Call) -> str | None:
    """The mode string of an ``open`` call ('r' when not given; None when not a literal)."""
    args = list(call.args)
    mode = None
    if isinstance(call.func, ast.Name):  # open(path, mode)
        mode = args[1] if len(args) > 1 else None
    elif args:  # path.open(mode)
        mode = args[0]
    for kw in call.keywords:
        if kw.arg == "mode":
            mode = kw.value
    if mode is None:
        return "r"
    return mode.value if isinstance(mode, ast.Constant) and isinstance(mode.value, str) else None


def reads_outside_the_opener(source: str) -> list[str]:
    """Calls in ``source`` that read a file without the opener: ``open``/``.open`` in a
    reading mode, ``read_text``/``read_bytes``, ``pd.read_*``/``pq.read_*``,
    ``json.load``/``tomllib.load`` on a handle."""
    found = []
    tree = ast.parse(source)
    opener = {alias.asname or alias.name for node in ast.walk(tree)
              if isinstance(node, ast.ImportFrom) and node.module == "etsid.files"
              for alias in node.names}
    for node in ast.walk(tree):
        if not isinstance(node, ast.Call):
            continue
        func = node.func
        name = func.id if isinstance(func, ast.Name) else (
            func.attr if isinstance(func, ast.Attribute) else "")
        owner = func.value.id if (isinstance(func, ast.Attribute)
                                  and isinstance(func.value, ast.Name)) else ""
        if isinstance(func, ast.Name) and name in opener:
            continue  # imported from etsid.files
        if name == "open" and owner not in ("os", "tarfile", "zipfile", "gzip", "bz2",
                                            "lzma", "webbrowser"):
            mode = _mode(node)
            writing = mode is not None and any(c in mode for c in "wax")
            own_copy = mode is not None and "+" in mode  # a file etsid made, updated in place
            if not (writing or own_copy):
                found.append(f"line {node.lineno}: {owner + '.' if owner else ''}open "
                             f"(mode {mode!r})")
        elif name in READ_CALLS and owner != "files":
            if name == "read_table" and owner in ("", "ingest"):  # etsid.ingest.read_table
                continue
            found.append(f"line {node.lineno}: {owner + '.' if owner else ''}{name}")
        elif (owner, name) in LOADERS or (owner == "shutil" and name in COPIES):
            found.append(f"line {node.lineno}: {owner}.{name}")
    return found


def test_no_file_is_read_outside_the_opener() -> None:
    offenders = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(ROOT).as_posix()
        if rel in ALLOWED:
            continue
        found = reads_outside_the_opener(path.read_text(encoding="utf-8"))
        if found:
            offenders[rel] = found
    assert offenders == {}, ("read these through etsid/files.py (open_binary, read_text, "
                             f"read_json, read_toml, read_parquet, …): {offenders}")


@pytest.mark.parametrize("source", [
    "data = Path(p).read_text()",
    "with open(p) as f: pass",
    "with path.open('rb') as f: pass",
    "frame = pd.read_parquet(p)",
    "t = pq.read_table(p)",
    "d = json.load(handle)",
    "d = tomllib.load(handle)",
    "shutil.copyfile(src, dst)",
    "from pandas import read_csv\nf = read_csv(p)",
])
def test_the_walker_sees_every_way_of_reading(source: str) -> None:
    assert reads_outside_the_opener(source), source


@pytest.mark.parametrize("source", [
    "path.write_text('x')",
    "with open(p, 'w') as f: pass",
    "with path.open('wb') as f: pass",
    "fd = os.open(os.devnull, os.O_WRONLY)",
    "d = files.read_json(p, 'run')",
    "t = files.read_parquet(p)",
    "from etsid.files import read_text\nx = read_text(p, 'list')",
])
def test_the_walker_lets_writes_and_the_opener_pass(source: str) -> None:
    assert reads_outside_the_opener(source) == [], source


def test_fifo_is_refused_without_blocking(tmp_path: Path) -> None:
    fifo = tmp_path / "v.toml"
    os.mkfifo(fifo)
    result: list[BaseException] = []

    def read() -> None:
        try:
            files.read_toml(fifo, "vehicle", SimError)
        except BaseException as err:
            result.append(err)

    worker = threading.Thread(target=read, daemon=True)
    worker.start()
    worker.join(5.0)
    assert not worker.is_alive(), "reading a FIFO blocked"
    assert isinstance(result[0], SimError) and "not a regular file but a FIFO" in str(result[0])


@pytest.mark.parametrize("target", ["/dev/zero", "/proc/self/status"])
def test_devices_and_proc_are_refused_through_a_link(tmp_path: Path, target: str) -> None:
    link = tmp_path / "x.json"
    link.symlink_to(target)
    with pytest.raises(EtsidError, match="x.json: .*(character device|proc/)"):
        files.read_json(link, "run")


def test_bytes_are_bounded_per_kind(tmp_path: Path) -> None:
    big = tmp_path / "v.toml"
    big.write_text('name = "' + "x" * (files.LIMITS["vehicle"] + 10) + '"\n')
    with pytest.raises(SimError, match=r"v.toml: 1 MiB is too large for one of the vehicle"):
        files.read_toml(big, "vehicle", SimError)
    # the same bytes are fine where the bound is larger
    assert files.read_text(big, "run").startswith('name = "x')


@pytest.mark.parametrize(("text", "reader"), [
    ("x = " + "[" * 100_000 + "]" * 100_000, files.loads_toml),
    ("x = " + "{a=" * 100_000 + "1" + "}" * 100_000, files.loads_toml),
    ("[" * 100_000 + "]" * 100_000, files.loads_json),
    ('{"a":' * 70 + "1" + "}" * 70, files.loads_json),
])
def test_nesting_is_bounded(text: str, reader) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(EtsidError, match="nested too deeply"):
        reader(text, "f")


def test_json_refuses_nan_and_infinity() -> None:
    with pytest.raises(EtsidError, match="not valid JSON"):
        files.loads_json('{"a": NaN}', "f")
    assert files.loads_json('{"a": [1, {"b": 2}]}', "f") == {"a": [1, {"b": 2}]}


def test_missing_file_is_one_line(tmp_path: Path) -> None:
    with pytest.raises(EtsidError, match=r"absent.json: no such file$"):
        files.read_json(tmp_path / "absent.json", "run")


CONTROLS = ["\x1b]52;c;QUFBQQ==\x07", "\x1b[2J", "\x9b31m", "a\rb", "a\nb", "\u202e",
            "\u2066x\u2069", "\u200f", "\x00", "\x7f"]


@pytest.mark.parametrize("text", CONTROLS)
def test_printable_leaves_no_control_or_bidi_character(text: str) -> None:
    shown = escape.printable(f"name{text}end")
    assert all(ch.isprintable() and ch not in "\u202e\u2066\u2069\u200f" for ch in shown), shown
    assert shown.startswith("name") and shown.endswith("end")


def test_clean_reaches_every_string_of_a_deep_document() -> None:
    deep: dict = {"k\x1b": ["\x1b", {"u": "\u202e"}], "n": 1.5}
    for _ in range(5000):  # deeper than Python's recursion limit: clean is iterative
        deep = {"x": deep}
    out = escape.clean(deep)
    for _ in range(5000):
        out = out["x"]
    assert out == {"k\\x1b": ["\\x1b", {"u": "\\u202e"}], "n": 1.5}


def test_sinks_escape_markup() -> None:
    assert escape.for_html('<img src=x onerror="a()">\u202e') == (
        "&lt;img src=x onerror=&quot;a()&quot;&gt;\\u202e")
    # etsid's own multi-line text (a rule base, config.json in a <pre>) keeps its lines
    assert escape.for_html("{\n\t\"a\": 1\r}\x1b") == "{\n\t&quot;a&quot;: 1\\x0d}\\x1b"
    assert escape.for_markdown("<b>|*") == "&lt;b&gt;\\|\\*"
