"""Seeded mutations of flight logs and rule bases, shared by tests/fuzz and benchmarks/fuzz.py.

A mutant is fully determined by (source, seed): the same pair gives the same bytes on
every machine, so a failure found by the benchmark is reproduced by adding its seed to
the test's list.
"""

from __future__ import annotations

import json
import multiprocessing as mp
import random
import resource
import shutil
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

SOURCES: dict[str, Path] = {
    "tlog": ROOT / "sample_logs" / "hexa_ige_oge.tlog",
    "ros1": ROOT / "sample_logs" / "hexa_ige_oge.bag",
    "mcap": ROOT / "sample_logs" / "hexa_ige_oge.mcap",
    "ros2-db3": ROOT / "sample_logs" / "hexa_ige_oge_db3",
    "ros2-mcap": ROOT / "sample_logs" / "hexa_ige_oge_mcap",
    "ulog": ROOT / "tests" / "data" / "px4_cubeorange_real.ulg",
    "bin": ROOT / "tests" / "data" / "arduplane_truncated.BIN",
}
"""Format → pristine log the mutants are made from (a ROS 2 bag is a directory)."""

KINDS = ("truncate", "flip", "zero4k", "duplicate", "append", "metadata")
"""Mutation kinds: cut the file, flip bytes, zero a 4 KiB page, repeat a stretch, append
garbage, damage a ROS 2 bag's metadata.yaml (directories only; otherwise a byte flip)."""


@dataclass(frozen=True)
class Mutant:
    """One mutated copy: where it is and what was done to it."""

    path: Path
    source: str
    seed: int
    what: str


def _target(src: Path) -> Path:
    """The file a mutation changes: the log itself, or a ROS 2 bag's storage file."""
    if src.is_dir():
        return next(p for p in sorted(src.iterdir()) if p.suffix in (".db3", ".mcap"))
    return src


def mutate_bytes(data: bytes, kind: str, rng: random.Random) -> tuple[bytes, str]:
    """``data`` changed by one mutation of ``kind``, and a description of the change."""
    n = len(data)
    buf = bytearray(data)
    if kind == "truncate":
        cut = rng.randrange(1, n)
        return bytes(buf[:cut]), f"truncated to {cut} of {n} bytes"
    if kind == "flip":
        count = rng.choice((1, 4, 10, 100))
        for _ in range(count):
            at = rng.randrange(n)
            buf[at] ^= 1 << rng.randrange(8) if rng.random() < 0.5 else rng.randrange(1, 256)
        return bytes(buf), f"{count} byte(s) flipped"
    if kind == "zero4k":
        at = rng.randrange(0, max(1, n - 4096))
        buf[at:at + 4096] = bytes(min(4096, n - at))
        return bytes(buf), f"4 KiB zeroed at byte {at}"
    if kind == "duplicate":
        at = rng.randrange(n)
        size = rng.choice((64, 1024, 16384, 65536))
        piece = bytes(buf[at:at + size])
        into = rng.randrange(n)
        return bytes(buf[:into]) + piece + bytes(buf[into:]), (
            f"{len(piece)} bytes from {at} duplicated at {into}")
    if kind == "append":
        size = rng.choice((1, 100, 4096, 100_000))
        tail = bytes(rng.randrange(256) for _ in range(size))
        return bytes(buf) + tail, f"{size} garbage bytes appended"
    raise ValueError(f"unknown mutation {kind!r}")


def _mutate_metadata(text: str, rng: random.Random) -> tuple[str, str]:
    lines = text.splitlines()
    at = rng.randrange(len(lines))
    line = lines[at]
    choice = rng.randrange(4)
    if choice == 0 and line.strip():
        pos = rng.randrange(len(line))
        lines[at] = line[:pos] + chr(rng.randrange(33, 127)) + line[pos + 1:]
        what = f"metadata.yaml line {at + 1}: one character changed"
    elif choice == 1:
        del lines[at]
        what = f"metadata.yaml line {at + 1} deleted"
    elif choice == 2:
        lines = lines[:at]
        what = f"metadata.yaml cut after line {at}"
    else:
        lines[at] = line.replace("9", "99999999999999999999")
        what = f"metadata.yaml line {at + 1}: numbers enlarged"
    return "\n".join(lines) + "\n", what


def make_mutant(source: str, seed: int, workdir: Path) -> Mutant:
    """Write the mutant ``seed`` of ``source`` (a key of :data:`SOURCES`) under ``workdir``."""
    rng = random.Random(f"{source}:{seed}")
    src = SOURCES[source]
    kind = rng.choice(KINDS)
    dest = workdir / f"{source}-{seed}"
    if src.is_dir():
        shutil.copytree(src, dest)
        if kind == "metadata":
            meta = dest / "metadata.yaml"
            text, what = _mutate_metadata(meta.read_text(), rng)
            meta.write_text(text)
            return Mutant(dest, source, seed, what)
        target = _target(dest)
    else:
        dest = dest.with_name(dest.name + src.suffix)
        target = dest
        if kind == "metadata":
            kind = "flip"
        shutil.copyfile(src, dest)
    data, what = mutate_bytes(target.read_bytes(), kind, rng)
    target.write_bytes(data)
    return Mutant(dest, source, seed, f"{target.name}: {what}")


# ---------------------------------------------------------------------------
# rule bases


def rules_variants(pristine: dict, workdir: Path, mutations: int = 12,
                   seed: int = 9) -> list[tuple[str, Path]]:
    """Hostile variants of a valid rules.json document: (what, path) pairs — the fixed
    list below, then ``mutations`` seeded byte-level mutations of the document."""
    out: list[tuple[str, Path]] = []

    def put(name: str, text: str) -> None:
        path = workdir / f"rules-{len(out):03d}.json"
        path.write_text(text)
        out.append((name, path))

    def doc_with(change) -> str:  # type: ignore[no-untyped-def]
        doc = json.loads(json.dumps(pristine))
        change(doc)
        return json.dumps(doc)

    def setter(path: list, value: object):  # type: ignore[no-untyped-def]
        def change(doc: dict) -> None:
            node = doc
            for key in path[:-1]:
                node = node[key]
            node[path[-1]] = value
        return change

    put("deep nesting", "[" * 100_000 + "]" * 100_000)
    put("deep object nesting", '{"a":' * 50_000 + "1" + "}" * 50_000)
    put("empty file", "")
    put("not json", "rules, please")
    put("a list", "[1, 2, 3]")
    put("huge integer", json.dumps(pristine).replace('"max_rules": ',
                                                      '"max_rules": 1' + "0" * 400 + " + ", 1)
        .replace(" + ", "", 1))
    for path, value, name in (
        (["sample_rate_hz"], "fast", "sample_rate_hz a string"),
        (["sample_rate_hz"], -5, "negative sample_rate_hz"),
        (["sample_rate_hz"], 1e9, "absurd sample_rate_hz"),
        (["sample_rate_hz"], 0, "zero sample_rate_hz"),
        (["params", "max_rules"], 1e9, "max_rules 1e9"),
        (["params", "max_rules"], 10**30, "max_rules beyond 64 bits"),
        (["rules"], [], "empty rule list"),
    ):
        put(name, doc_with(setter(path, value)))
    text = json.dumps(pristine)
    for needle, repl, name in (
        ('"potential": ', '"potential": NaN, "x": ', "NaN potential"),
        ('"focal": [', '"focal": [1e308, ', "focal point at 1e308"),
        ('"focal": [', '"focal": [Infinity, ', "infinite focal point"),
    ):
        if needle in text:
            put(name, text.replace(needle, repl, 1))
    for depth in (1, 2):
        doc = json.loads(text)
        doc["rules"] = doc.get("rules", [])[:1] * (10 ** (2 + depth))
        put(f"{10 ** (2 + depth)} copies of one rule", json.dumps(doc))
    rng = random.Random(seed)
    data = text.encode()
    for i in range(mutations):
        kind = ("truncate", "flip", "duplicate", "append")[i % 4]
        mutated, what = mutate_bytes(data, kind, rng)
        put(f"rules.json {what}", mutated.decode("utf-8", "replace"))
    return out


# ---------------------------------------------------------------------------
# running one mutant

OUTCOMES = ("read ok", "clean error", "internal error", "timeout", "implausible",
            "raw output")
"""How a run ends: a table written and plausible; one ``etsid: error:`` line naming the
file; the catch-all ``etsid: internal error`` or an escaped exception; no end within the
time bound; a written table holding values beyond the plausibility limits; a Python
warning or traceback on stderr."""


@dataclass
class Outcome:
    """The verdict on one run, with what the command printed."""

    kind: str
    detail: str
    seconds: float = 0.0


def run_cli(args: list[str], checked_path: Path | None = None, names: str = "") -> Outcome:
    """Run ``etsid ARGS`` in this process and classify it (see :data:`OUTCOMES`).

    ``checked_path``: a table the command may have written, checked for implausible values.
    ``names``: a string a clean error must contain (the input file's name).
    """
    import time
    import warnings

    from click.testing import CliRunner

    from etsid.cli import cli
    from etsid.ingest.plausibility import table_violations
    from etsid.table import load_table

    start = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = CliRunner().invoke(cli, args, catch_exceptions=True)
    seconds = time.perf_counter() - start
    err = result.stderr
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        exc = result.exception
        return Outcome("internal error", f"{type(exc).__name__}: {exc}"[:300], seconds)
    if "internal error" in err:
        return Outcome("internal error", err.strip()[:300], seconds)
    if "Traceback" in err or "Warning:" in err or caught:
        text = "; ".join(f"{w.category.__name__}: {w.message}" for w in caught) or err.strip()
        return Outcome("raw output", text[:300], seconds)
    if result.exit_code != 0:
        lines = [ln for ln in err.splitlines() if ln.strip()]
        if (result.exit_code == 1 and len(lines) == 1 and lines[0].startswith("etsid: error: ")
                and names in lines[0]):
            return Outcome("clean error", lines[0][:300], seconds)
        return Outcome("internal error", f"exit {result.exit_code}: {err.strip()[:300]}",
                       seconds)
    if checked_path is not None and checked_path.exists():
        table = load_table(checked_path)
        bad = table_violations(table)
        if bad:
            return Outcome("implausible", f"{bad}", seconds)
    return Outcome("read ok", result.stdout.strip().splitlines()[0][:300]
                   if result.stdout.strip() else "", seconds)


def run_ingest(mutant: Mutant, workdir: Path) -> Outcome:
    """``etsid ingest MUTANT -o TABLE`` classified; the table is checked for plausibility."""
    out = workdir / f"{mutant.path.name}.parquet"
    return run_cli(["ingest", str(mutant.path), "-o", str(out)], out, mutant.path.name)


# ---------------------------------------------------------------------------
# worker processes with a memory limit and a time bound


def _worker(tasks: mp.Queue, results: mp.Queue, memory_gb: float) -> None:
    limit = int(memory_gb * 2**30)
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    while True:
        task = tasks.get()
        if task is None:
            return
        source, seed, root = task
        with tempfile.TemporaryDirectory(dir=root) as tmp:
            work = Path(tmp)
            try:
                mutant = make_mutant(source, seed, work)
                outcome = run_ingest(mutant, work)
                what = mutant.what
            except MemoryError as err:
                outcome, what = Outcome("internal error", f"MemoryError {err}"), "?"
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        results.put((source, seed, what, outcome.kind, outcome.detail, outcome.seconds, peak))


SPAWN = mp.get_context("spawn")
"""Workers are spawned, never forked: a fork of a process that already runs pyarrow's or
numba's threads can hang in the child (seen: pyarrow's thread pool in ``save_table``)."""


class Pool:
    """Worker processes fed one task at a time, so that a hung one can be killed alone."""

    def __init__(self, jobs: int, memory_gb: float) -> None:
        self.memory_gb = memory_gb
        self.slots = [self._start() for _ in range(jobs)]

    def _start(self) -> dict:
        tasks: mp.Queue = SPAWN.Queue()
        results: mp.Queue = SPAWN.Queue()
        proc = SPAWN.Process(target=_worker, args=(tasks, results, self.memory_gb), daemon=True)
        proc.start()
        return {"proc": proc, "tasks": tasks, "results": results, "task": None, "since": 0.0}

    def run(self, todo: list[tuple[str, int]], root: str, timeout: float):
        todo = list(todo)
        while todo or any(s["task"] for s in self.slots):
            for i, slot in enumerate(self.slots):
                if slot["task"] is None and todo:
                    slot["task"] = todo.pop(0)
                    slot["since"] = time.monotonic()
                    slot["tasks"].put((*slot["task"], root))
                if slot["task"] is None:
                    continue
                try:
                    yield slot["results"].get(timeout=0.05)
                    slot["task"] = None
                    continue
                except Exception:  # queue.Empty
                    pass
                dead = not slot["proc"].is_alive()
                if dead or time.monotonic() - slot["since"] > timeout:
                    source, seed = slot["task"]
                    slot["proc"].kill()
                    slot["proc"].join()
                    kind = "internal error" if dead else "timeout"
                    why = (f"worker died (exit {slot['proc'].exitcode})" if dead
                           else f"no end after {timeout:.0f} s")
                    yield (source, seed, "?", kind, why, timeout, float("nan"))
                    self.slots[i] = self._start()

    def close(self) -> None:
        for slot in self.slots:
            slot["tasks"].put(None)
            slot["proc"].join(timeout=5)
            if slot["proc"].is_alive():
                slot["proc"].kill()
