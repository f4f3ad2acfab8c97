"""Hostile files beside the logs (issue 42): sidecars, vehicle files, run and batch folders,
list files, table metadata and ``--set`` values, each run like :mod:`structure`'s cases.

Every case builds its input with etsid's own writers (a table saved by ``save_table``, a
run folder written by ``etsid identify``, a batch folder written by ``etsid batch``), then
edits one thing the way a hostile sender would, and says what a correct run gives: one
``etsid: error:`` line, or a result whose files pass ``check`` (no raw markup in a
report, no raw control characters, every simulated value finite).

``python benchmarks/fuzz.py --files`` runs every case; tests/fuzz/test_files.py runs the
cheap ones in CI (the report cases run in Chromium in tests/report/test_hostile_pages.py).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import structure
from structure import Case

ROOT = structure.ROOT
GAS = ROOT / "tests" / "data" / "gas_furnace.csv"
TARGET = ROOT / "etsid" / "sim" / "vehicles" / "quad250.toml"
SCRIPT = "<img src=x onerror=alert(42)>"
OSC52 = "\x1b]52;c;QUFBQQ==\x07"
RLO = "\u202e"
RAW = ("\x1b", "\x07", "\x9b", RLO)
REPORT_S = 120.0
"""Time bound of a report (a batch folder's builds every flight's page): more than the
30 s of the other cases, on a machine shared by several jobs."""
SIM_S = 120.0
"""Time bound of a simulation: the first run on a machine compiles the simulator's numba
kernels (about a minute on a shared machine; a few seconds once cached)."""
CACHE = Path(os.environ.get("ETSID_FUZZ_CACHE", "/tmp/etsid-fuzz-cache"))
"""Run and batch folders made once (``etsid identify`` compiles for a minute)."""


# ---------------------------------------------------------------------------
# builders


def _table(path: Path, attrs: dict | None = None, rows: int = 400) -> Path:
    """A small FlightTable saved by etsid's own writer (Parquet or CSV by suffix)."""
    import numpy as np
    import pandas as pd

    from etsid.table import save_table

    t = np.arange(rows) / 50.0
    rng = np.random.default_rng(0)
    frame = pd.DataFrame({"p": np.sin(t), "q": np.cos(t), "r": 0.1 * np.sin(2 * t),
                          "u_roll": rng.normal(size=rows) * 0.1}, index=pd.Index(t, name="t"))
    frame.attrs = {"source": str(path), "format": "table", "warnings": []}
    if attrs is not None:
        frame.attrs = attrs
    save_table(frame, path)
    return path


def _parquet_attrs(value: object, raw: str | None = None) -> Callable[[Path], Path]:
    """A Parquet table whose ``etsid.attrs`` metadata is ``value`` as JSON (or ``raw``)."""
    def build(work: Path) -> Path:
        import pyarrow.parquet as pq

        path = _table(work / "t.parquet")
        arrow = pq.read_table(path)
        meta = dict(arrow.schema.metadata or {})
        meta[b"etsid.attrs"] = (json.dumps(value) if raw is None else raw).encode()
        pq.write_table(arrow.replace_schema_metadata(meta), path)
        return path

    return build


def _sidecar(kind: str) -> Callable[[Path], Path]:
    """A CSV table whose sidecar ``x.csv.attrs.json`` is a FIFO or a link to /dev/zero."""
    def build(work: Path) -> Path:
        path = _table(work / "x.csv")
        side = work / "x.csv.attrs.json"
        side.unlink()
        if kind == "fifo":
            os.mkfifo(side)
        else:
            side.symlink_to("/dev/zero")
        return path

    return build


def _vehicle_text(text: str, name: str = "v.toml") -> Callable[[Path], Path]:
    def build(work: Path) -> Path:
        path = work / name
        path.write_text(text)
        return path

    return build


def _vehicle_edit(pattern: str, repl: str) -> Callable[[Path], Path]:
    """The packaged quad250 with one line changed (``re.sub`` on the TOML text)."""
    def build(work: Path) -> Path:
        text, count = re.subn(pattern, repl, TARGET.read_text(), count=1, flags=re.M)
        assert count == 1, pattern
        path = work / "v.toml"
        path.write_text(text)
        return path

    return build


def _vehicle_special(kind: str) -> Callable[[Path], Path]:
    def build(work: Path) -> Path:
        path = work / "v.toml"
        if kind == "fifo":
            os.mkfifo(path)
        else:
            path.symlink_to("/dev/zero")
        return path

    return build


def _vehicle_big_string(work: Path) -> Path:
    path = work / "v.toml"
    with path.open("w") as out:
        out.write('name = "')
        for _ in range(200):
            out.write("x" * (1 << 20))
        out.write('"\n')
    return path


def _vehicle_nested(kind: str, depth: int = 100_000) -> Callable[[Path], Path]:
    def build(work: Path) -> Path:
        path = work / "v.toml"
        body = ("[" * depth + "]" * depth if kind == "array"
                else "{a=" * depth + "1" + "}" * depth)
        path.write_text(f"x = {body}\n")
        return path

    return build


def _vehicle_rotors(count: int) -> Callable[[Path], Path]:
    def build(work: Path) -> Path:
        text = TARGET.read_text()
        angles = ", ".join(f"{360.0 * i / count:.4f}" for i in range(count))
        spins = ", ".join('"cw"' if i % 2 else '"ccw"' for i in range(count))
        text = re.sub(r"^angles_deg = .*$", f"angles_deg = [{angles}]", text, flags=re.M)
        text = re.sub(r"^spin = .*$", f"spin = [{spins}]", text, flags=re.M)
        path = work / "v.toml"
        path.write_text(text)
        return path

    return build


def _list_file(lines: list[str]) -> Callable[[Path], Path]:
    def build(work: Path) -> Path:
        _table(work / "good.parquet")
        path = work / "inputs.txt"
        path.write_text("\n".join([*lines, "good.parquet"]) + "\n")
        return path

    return build


def _cached_run() -> Path:
    """A run folder written by ``etsid identify`` on the gas-furnace table, made once."""
    run = CACHE / "run"
    if not (run / "metrics.json").is_file():
        CACHE.mkdir(parents=True, exist_ok=True)
        subprocess.run([sys.executable, "-m", "etsid", "identify", str(GAS), "--output",
                        "co2", "--regressors", "co2[k-1],input_gas_rate[k-4]", "--out",
                        str(run), "--quiet"], check=True, capture_output=True,
                       env=structure.child_env())
    return run


def _cached_batch() -> Path:
    """A batch folder written by ``etsid batch identify`` on two small tables, made once."""
    batch = CACHE / "batch"
    if not (batch / "batch.json").is_file():
        CACHE.mkdir(parents=True, exist_ok=True)
        logs = CACHE / "logs"
        logs.mkdir(exist_ok=True)
        for name in ("a", "b"):
            shutil.copy(GAS, logs / f"{name}.csv")
        subprocess.run([sys.executable, "-m", "etsid", "batch", "identify",
                        str(logs / "a.csv"), str(logs / "b.csv"),
                        "--output", "co2", "--regressors", "co2[k-1],input_gas_rate[k-4]",
                        "-j", "1", "-o", str(batch), "--quiet"], check=True,
                       capture_output=True, env=structure.child_env())
    return batch


def _run_edit(edit: Callable[[dict], None], file: str = "metrics.json",
              name: str = "run") -> Callable[[Path], Path]:
    """A copy of the cached run folder with one JSON file edited."""
    def build(work: Path) -> Path:
        run = work / name
        shutil.copytree(_cached_run(), run, ignore=shutil.ignore_patterns("report"))
        path = run / file
        data = json.loads(path.read_text())
        edit(data)
        path.write_text(json.dumps(data))
        return run

    return build


def _set_unit(data: dict) -> None:
    for out in data["outputs"].values():
        out["unit"] = SCRIPT


def _set_warnings(data: dict) -> None:
    data.setdefault("warnings", []).append(f"clipboard {OSC52} {SCRIPT}")


def _batch_edit(edit: Callable[[Path], None]) -> Callable[[Path], Path]:
    def build(work: Path) -> Path:
        batch = work / "batch"
        shutil.copytree(_cached_batch(), batch, symlinks=True,
                        ignore=shutil.ignore_patterns("report"))
        edit(batch)
        return batch

    return build


def _batch_json_wall(batch: Path) -> None:
    path = batch / "batch.json"
    data = json.loads(path.read_text())
    data["wall_s"] = "slow"
    path.write_text(json.dumps(data))


def _results_fit(value: float) -> Callable[[Path], None]:
    def edit(batch: Path) -> None:
        import pandas as pd
        import pyarrow as pa
        import pyarrow.parquet as pq

        for file in (batch / "results").rglob("*.parquet"):
            frame = pq.read_table(file).to_pandas()
            for col in frame.columns:
                named = col.startswith("fit") or col.endswith("_fit") or "fit_" in col
                if named and pd.api.types.is_float_dtype(frame[col]):
                    frame[col] = value
            pq.write_table(pa.Table.from_pandas(frame, preserve_index=False), file)

    return edit


# ---------------------------------------------------------------------------
# checks of what a successful run wrote


def _report_clean(run: Path) -> str:
    """A report of ``run`` with no raw control/bidi character and no live markup."""
    for name in ("report.md", "index.html"):
        file = run / "report" / name
        if not file.is_file():
            return f"no report/{name}"
        text = file.read_text(encoding="utf-8", errors="replace")
        for bad in RAW:
            if bad in text:
                return f"raw {bad!r} in report/{name}"
        if name == "report.md":  # code blocks and spans show their text literally
            prose = re.sub(r"`[^`]*`", "", re.sub(r"```.*?```", "", text, flags=re.S))
            if SCRIPT in prose:
                return "raw markup in report.md"
        if name == "index.html":
            for match in re.finditer(r'"tooltips":\[(.*?)\]\]', text):
                templates = re.findall(r'\["(?:[^"\\]|\\.)*","((?:[^"\\]|\\.)*)"',
                                       match.group(1))
                if any("onerror" in t for t in templates):
                    return "the file's string is inside a Bokeh tooltip template (HTML)"
            body = re.sub(r"<script.*?</script>", "", text, flags=re.S)
            if SCRIPT in body:
                return "raw markup in index.html"
    return ""


def _quiet_warnings(text: str) -> str:
    return "a raw Python warning printed" if "Warning:" in text else ""


SIM = ("simulate", "hover-oge", "--duration", "2", "--rate", "50", "-o", "{out}")
VEH = ("simulate", "hover-oge", "--duration", "2", "--rate", "50", "--vehicle", "{in}", "-o",
       "{out}")


def _sim_set(*items: str) -> tuple[str, ...]:
    return (*SIM, *[x for item in items for x in ("--set", item)])


def _none(work: Path) -> Path:
    return work


CASES: list[Case] = [
    # 1. files opened without the guards
    Case("sidecar-fifo", _sidecar("fifo"), error=True, cheap=True,
         what="x.csv whose x.csv.attrs.json is a FIFO (ingest)"),
    Case("sidecar-dev-zero", _sidecar("zero"), error=True,
         what="x.csv whose x.csv.attrs.json links to /dev/zero (ingest)"),
    Case("vehicle-fifo", _vehicle_special("fifo"), args=VEH, error=True, cheap=True,
         seconds=SIM_S,
         what="simulate --vehicle FIFO"),
    Case("vehicle-dev-zero", _vehicle_special("zero"), args=VEH, error=True,
         seconds=SIM_S,
         what="simulate --vehicle → /dev/zero"),
    Case("vehicle-200mb-string", _vehicle_big_string, args=VEH, error=True,
         seconds=SIM_S,
         what="vehicle file holding a 200 MB string"),
    Case("vehicle-nested-arrays", _vehicle_nested("array"), args=VEH, error=True, cheap=True,
         seconds=SIM_S,
         what="vehicle file of 10^5 nested arrays"),
    Case("vehicle-nested-tables", _vehicle_nested("table"), args=VEH, error=True,
         seconds=SIM_S,
         what="vehicle file of 10^5 nested inline tables"),
    Case("gap-vehicle-fifo", _vehicle_special("fifo"), error=True,
         args=("gap", str(ROOT / "sample_logs" / "hexa_ige_oge.mcap"),
               str(ROOT / "sample_logs" / "hexa_ige_oge.mcap"), "--vehicle", "{in}",
               "--out", "{out}"), what="gap --vehicle FIFO"),
    Case("list-dev-zero-url", _list_file(["file:///dev/zero"]),
         args=("batch", "inspect", "{in}", "--out", "{out}", "-j", "1", "-q"),
         note=("/dev/zero",), what="batch list holding file:///dev/zero (an error row)"),
    # 2. files etsid wrote, read back without a schema
    Case("attrs-list", _parquet_attrs([1, 2]), error=True, cheap=True,
         what="Parquet etsid.attrs that is a list"),
    Case("attrs-string", _parquet_attrs("x"), error=True,
         what="Parquet etsid.attrs that is a string"),
    Case("attrs-warnings-int", _parquet_attrs({"warnings": 5}), error=True,
         what='Parquet etsid.attrs {"warnings": 5}'),
    Case("attrs-rate-string", _parquet_attrs({"rate_hz": "fast"}), error=True,
         what='Parquet etsid.attrs {"rate_hz": "fast"}'),
    Case("attrs-deep", _parquet_attrs(None, "[" * 100_000 + "]" * 100_000), error=True,
         what="Parquet etsid.attrs nested 10^5 deep"),
    Case("batch-json-wall", _batch_edit(_batch_json_wall), args=("report", "{in}"),
         error=True, seconds=REPORT_S,
         what="batch.json with wall_s a string (fleet report)"),
    Case("results-fit-1e308", _batch_edit(_results_fit(1e308)), args=("report", "{in}"),
         check=lambda out, p, text: _quiet_warnings(text), note=("left out",), seconds=REPORT_S,
         what="result rows with fit 1e308"),
    Case("results-fit-inf", _batch_edit(_results_fit(float("inf"))), args=("report", "{in}"),
         check=lambda out, p, text: _quiet_warnings(text), note=("left out",), seconds=REPORT_S,
         what="result rows with fit inf"),
    Case("metrics-outputs-list", _run_edit(lambda d: d.update(outputs=[1])),
         args=("report", "{in}"), error=True, seconds=REPORT_S,
         what="metrics.json outputs a list (report)"),
    # 3. settings without physical ranges
    Case("set-duration-1e7", _none, args=("simulate", "hover-oge", "--rate", "50", "-o", "{out}",
                                           "--set", "scenario.duration=1e7"), error=True,
         cheap=True, seconds=SIM_S,
         what="--set scenario.duration=1e7"),
    Case("set-time-delay-1e9", _none, args=_sim_set("vehicle.time_delay=1e9"), error=True,
         seconds=SIM_S,
         what="--set vehicle.time_delay=1e9"),
    Case("set-altitude-1e308", _none, args=_sim_set("scenario.altitude=1e308"), error=True,
         seconds=SIM_S,
         what="--set scenario.altitude=1e308"),
    Case("vehicle-izz-tiny", _vehicle_edit(r"^izz = .*$", "izz = 1e-300"), args=VEH,
         error=True, seconds=SIM_S,
         what="vehicle izz = 1e-300"),
    Case("vehicle-tau-tiny", _vehicle_edit(r"^time_constant = .*$", "time_constant = 1e-300"),
         args=VEH, error=True, seconds=SIM_S,
         what="vehicle motor.time_constant = 1e-300"),
    Case("vehicle-omega-huge", _vehicle_edit(r"^omega_max = .*$", "omega_max = 1e300"),
         args=VEH, error=True, seconds=SIM_S,
         what="vehicle motor.omega_max = 1e300"),
    Case("vehicle-cells-huge", _vehicle_edit(r"^cells = .*$", "cells = 9223372036854775807"),
         args=VEH, error=True, seconds=SIM_S,
         what="vehicle battery.cells = 2^63-1"),
    Case("vehicle-rotors-coincide",
         _vehicle_edit(r"^angles_deg = .*$", "angles_deg = [0.0, 0.0, 0.0, 0.0]"), args=VEH,
         error=True, seconds=SIM_S,
         what="vehicle with every rotor at 0°"),
    Case("vehicle-rangefinder-tiny",
         _vehicle_edit(r"^rangefinder_hz = .*$", "rangefinder_hz = 1e-300"), args=VEH,
         error=True, seconds=SIM_S,
         what="vehicle sensors.rangefinder_hz = 1e-300"),
    Case("vehicle-10k-rotors", _vehicle_rotors(10_000), args=VEH, error=True,
         seconds=SIM_S,
         what="vehicle with 10^4 rotors"),
    Case("vehicle-tiny-mass-hover", _vehicle_edit(r"^mass = .*$", "mass = 1e-9"), args=VEH,
         error=True,
         seconds=SIM_S,
         what="vehicle of 1e-9 kg"),
    # 4. strings from files reaching terminal and pages raw
    Case("attrs-warning-osc52",
         _parquet_attrs({"source": "x", "format": "table", "warnings": [f"w {OSC52}"]}),
         absent=RAW, note=("\\x1b]52",), cheap=True,
         what="a table's attrs warning holding OSC 52 (ingest's terminal)"),
    Case("report-unit-script", _run_edit(_set_unit), args=("report", "{in}"),
         check=lambda out, p, text: _report_clean(p), absent=RAW,
         seconds=REPORT_S,
         what="metrics.json unit <img onerror> (report)"),
    Case("report-warning-osc52", _run_edit(_set_warnings, "config.json"),
         args=("report", "{in}"),
         check=lambda out, p, text: _report_clean(p), absent=RAW,
         seconds=REPORT_S,
         what="config.json warnings with OSC 52 and markup (report)"),
    Case("report-bidi-name", _run_edit(lambda d: None, name=f"run{RLO}lmth.exe"),
         args=("report", "{in}"), check=lambda out, p, text: _report_clean(p), absent=RAW,
         seconds=REPORT_S,
         what="a run folder named with U+202E (report title and h1)"),
    # 5. batch
    Case("list-long-line", _list_file(["x" * 5000]),
         args=("batch", "inspect", "{in}", "--out", "{out}", "-j", "1", "-q"),
         check=lambda out, p, text: "" if "internal error" not in text else "internal error",
         what="a 5000-character line in a batch list (an error row, the rest run)"),
]
"""Every hostile file of issue 42, in its order."""


def case(name: str) -> Case:
    """The case called ``name``."""
    return next(c for c in CASES if c.name == name)


def _bag_dir_bomb(work: Path, nbytes: int = 4 << 30) -> Path:
    """The sample MCAP-storage ROS 2 bag directory whose storage file holds one lz4 chunk
    of ``nbytes`` zeros declared as 1 MiB (rewritten with the mcap writer, 64 KiB chunks)."""
    bag = work / "bomb_bag"
    shutil.copytree(ROOT / "sample_logs" / "hexa_ige_oge_mcap", bag)
    storage = bag / "hexa_ige_oge_mcap.mcap"
    source = work / "source.mcap"
    storage.rename(source)
    structure._rewrite_mcap(source, storage, lambda *_: None, chunk_size=64 << 10)
    source.unlink()
    times = [m.log_time for _, _, m in structure._mcap_messages(storage)]
    chunk = structure._chunk_record("lz4", structure._lz4_zeros(nbytes), 1 << 20, min(times),
                                    max(times))
    storage.write_bytes(structure._insert_before_data_end(storage.read_bytes(), chunk))
    return bag


def _bag_dir_lying_chunk(indexed: bool = True, nbytes: int = 4 << 30,
                         declared: int | None = None) -> Callable[[Path], Path]:
    """The sample MCAP-storage ROS 2 bag directory rewritten by mcap's writer (lz4, 64 KiB
    chunks) with its first chunk's compressed bytes replaced, as it is written, by an lz4
    frame of ``nbytes`` zeros; that chunk's header keeps the real (small) uncompressed size,
    or states ``declared``. The chunk stays in the summary's chunk index, so rosbags'
    storage plugin decompresses it; ``indexed=False`` writes no summary, so rosbags
    decompresses every chunk already when it opens the bag."""
    def build(work: Path) -> Path:
        from unittest import mock

        import lz4.frame
        from mcap.writer import CompressionType, IndexType, Writer

        bag = work / "lying_bag"
        shutil.copytree(ROOT / "sample_logs" / "hexa_ige_oge_mcap", bag)
        storage = bag / "hexa_ige_oge_mcap.mcap"
        source = work / "source.mcap"
        storage.rename(source)
        real = lz4.frame.compress
        bomb = structure._lz4_zeros(nbytes) if nbytes else b""
        calls = [0]

        def compress(data: bytes, *args: object, **kwargs: object) -> bytes:
            calls[0] += 1
            return bomb if calls[0] == 1 and nbytes else real(data, *args, **kwargs)

        with storage.open("wb") as out, mock.patch.object(lz4.frame, "compress", compress):
            writer = Writer(out, chunk_size=64 << 10, compression=CompressionType.LZ4,
                            use_summary_offsets=indexed, use_statistics=indexed,
                            index_types=IndexType.ALL if indexed else IndexType.NONE)
            schemas: dict[int, int] = {}
            channels: dict[int, int] = {}
            writer.start("ros2", "etsid file fuzzer")
            for schema, channel, message in structure._mcap_messages(source):
                if schema.id not in schemas:
                    schemas[schema.id] = writer.register_schema(schema.name, schema.encoding,
                                                                schema.data)
                if channel.id not in channels:
                    channels[channel.id] = writer.register_channel(
                        channel.topic, channel.message_encoding, schemas[schema.id],
                        channel.metadata)
                writer.add_message(channels[channel.id], message.log_time, message.data,
                                   message.publish_time)
            writer.finish()
        source.unlink()
        if declared is not None:
            _set_first_chunk_size(storage, declared)
        return bag

    return build


def _set_first_chunk_size(path: Path, declared: int) -> None:
    """Overwrite the uncompressed size stated by the first chunk record of ``path`` (in
    the record and in its chunk index entry, when there is one)."""
    import struct

    data = bytearray(path.read_bytes())
    pos = 8
    while pos < len(data):
        op, length = struct.unpack_from("<BQ", data, pos)
        if op == 6:
            struct.pack_into("<Q", data, pos + 9 + 16, declared)
            break
        pos += 9 + length
    first = pos
    pos = 8
    while pos < len(data) - 8:
        op, length = struct.unpack_from("<BQ", data, pos)
        if op == 8 and struct.unpack_from("<Q", data, pos + 9 + 16)[0] == first:
            # chunk index: start, end, chunk offset, length, offsets map, index length,
            # compression string, compressed size, uncompressed size
            (n,) = struct.unpack_from("<I", data, pos + 9 + 32)
            at = pos + 9 + 32 + 4 + n + 8
            (k,) = struct.unpack_from("<I", data, at)
            struct.pack_into("<Q", data, at + 4 + k + 8, declared)
        pos += 9 + length
    path.write_bytes(bytes(data))


CASES += [
    Case("bagdir-mcap-lying-chunk", _bag_dir_lying_chunk(), columns=structure.RATES,
         rows=2800, note=("skipped 1 damaged stretch", "decompresses to more than"), cheap=True,
         what="ROS 2 bag directory (MCAP storage, indexed): its first chunk's lz4 data "
              "replaced by 4 GiB of zeros, the header stating 64 KiB (rosbags' path)"),
    Case("bagdir-mcap-lying-chunk-unindexed", _bag_dir_lying_chunk(indexed=False),
         columns=structure.RATES, rows=2800, note=("skipped 1 damaged stretch",),
         what="the same without chunk index (rosbags decompresses every chunk at open)"),
    Case("bagdir-mcap-chunk-declares-1tib", _bag_dir_lying_chunk(nbytes=1 << 20,
                                                                  declared=1 << 40),
         columns=structure.RATES, rows=2800, note=("skipped 1 damaged stretch", "declares"),
         what="ROS 2 bag directory (MCAP storage): a chunk (and its index entry) declaring "
              "1 TiB decompressed, far above the file's size"),
]
CASES.append(Case("bagdir-mcap-lz4-bomb", _bag_dir_bomb, columns=structure.RATES, rows=2900,
                  what="ROS 2 bag directory (MCAP storage): a 4 GiB lz4 chunk of zeros "
                       "declared as 1 MiB (the rosbags storage path)"))
