"""Markup and terminal escapes through the string-carrying fields of the files beside a table
and a run (those are in test_hostile_pages.py): a log's topic and field names, a mapping
file, a vehicle file, a rule base and a gap folder's gap.json.

The logs are written by the real writers: a ROS 1 bag by rosbags (sensor_msgs/Imu and
mavros_msgs/RCOut topics named with markup, OSC 52 and U+202E) and an MCAP file by mcap
(JSON messages whose Imu topic, field names, schema title, library and metadata carry them;
a mapping file maps p and q to the hostile fields). The vehicle file carries them in its name
and description (simulate, control, gap), and in turn in every other string field, an
unknown key and a number (each a one-line error). Every string of a rule base and of a
gap.json the schema lets hold any text gets them too. Checked: the terminal output of every
command (inspect, ingest, identify, report, simulate, control, gap, rules, predict), each
report.md, and the DOM of each page in headless Chromium after moving the mouse across every
plot — no handler runs, no live markup, no raw escape or bidi character, and ``<pre>``
blocks keep their line breaks.
"""

from __future__ import annotations

import copy
import json
import shutil
import tomllib
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from hostile import (
    ESCAPES,
    FIELD_PAYLOAD,
    PAYLOAD,
    RLO,
    ROOT,
    SHOWN,
    assert_page_safe,
    chromium,
    hover_everything,
    invoke,
    live_markup,
    raw_in,
    require_browser,
    run,
)

require_browser()

SAMPLE = ROOT / "sample_logs" / "low_hover_1.parquet"
OTHER = ROOT / "sample_logs" / "low_hover_2.parquet"
GAS = ROOT / "tests" / "data" / "gas_furnace.csv"
HOSTILE = PAYLOAD + ESCAPES + RLO
"""Appended to a string a file carries."""
TOPIC_SUFFIX = "/" + HOSTILE
FIELD = FIELD_PAYLOAD + "\x1b]52;c;QUFBQQ==\x07\x9b31m" + RLO
"""A field or topic part without a dot or a bracket (a mapping names TOPIC.FIELD[i])."""


@pytest.fixture(scope="module")
def browser() -> Any:
    yield from chromium()


def _ros1_bag(path: Path) -> Path:
    """The sample flight as a ROS 1 bag (rosbags' writer) whose Imu and RCOut topics carry
    markup and escapes."""
    from rosbags.rosbag1 import Writer

    from etsid.rosmsgs import typestore
    from etsid.sim.writers.rosbag import instantiate, mavros_messages
    from etsid.table import load_table

    store = typestore(ros1=True)
    topics, messages = mavros_messages(load_table(SAMPLE))
    renamed = {t: t + TOPIC_SUFFIX if t.endswith(("/imu/data", "/rc/out")) else t
               for t, _ in topics}
    with Writer(path) as writer:
        conns = {t: writer.add_connection(renamed[t], msgtype, typestore=store)
                 for t, msgtype in topics}
        for log_ns, _, topic, msgtype, fields in messages:
            msg = instantiate(store, msgtype, fields)
            writer.write(conns[topic], log_ns, store.serialize_ros1(msg, msgtype))
    return path


def _json_mcap(path: Path) -> Path:
    """The sample flight as an MCAP file of JSON messages (mcap's writer): the Imu topic, two
    extra Imu fields, the schema title, the library and the metadata carry markup and
    escapes."""
    from mcap.writer import Writer

    from etsid.sim.writers.mcapfile import _json_schema, _plain
    from etsid.sim.writers.rosbag import mavros_messages
    from etsid.table import load_table

    _, messages = mavros_messages(load_table(SAMPLE))
    with path.open("wb") as handle:
        writer = Writer(handle)
        writer.start(profile="", library="etsid-test " + HOSTILE)
        channels: dict[str, int] = {}
        for log_ns, _, topic, msgtype, fields in messages:
            if topic.endswith("/imu/data"):
                fields = {**fields, FIELD: 2.0,
                          "angular_velocity": {**fields["angular_velocity"], "x" + FIELD: 1.0}}
            if topic not in channels:
                schema = dict(_json_schema(fields), title=msgtype + HOSTILE)
                sid = writer.register_schema(name=msgtype, encoding="jsonschema",
                                             data=json.dumps(schema).encode())
                name = topic + "/" + FIELD if topic.endswith("/imu/data") else topic
                channels[topic] = writer.register_channel(
                    topic=name, message_encoding="json", schema_id=sid,
                    metadata={"k" + HOSTILE: "v" + HOSTILE})
            writer.add_message(channel_id=channels[topic], log_time=log_ns,
                               publish_time=log_ns, data=json.dumps(_plain(fields)).encode())
        writer.add_metadata("meta" + HOSTILE, {"k" + HOSTILE: "v" + HOSTILE})
        writer.finish()
    return path


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """The hostile bag and MCAP file inspected and ingested; the bag identified and
    reported (p from the hostile Imu topic, m1 from the hostile RCOut topic)."""
    root = tmp_path_factory.mktemp("logs")
    bag, mcap = _ros1_bag(root / "h.bag"), _json_mcap(root / "h.mcap")
    imu = "/mavros/imu/data/" + FIELD
    mapping = root / "map.toml"
    mapping.write_text("[map]\n"
                       f"p = {json.dumps(f'{imu}.angular_velocity.x{FIELD}')}\n"
                       f"q = {json.dumps(f'{imu}.{FIELD}')}\n", encoding="utf-8")
    printed = {
        "inspect bag": run("inspect", bag, "-q"),
        "inspect bag --json": run("inspect", bag, "--json", "-q"),
        "ingest bag": run("ingest", bag, "-o", root / "bag.parquet", "-q"),
        "inspect mcap": run("inspect", mcap, "-q"),
        "inspect mcap --mapping": run("inspect", mcap, "--mapping", mapping, "-q"),
        "ingest mcap --mapping": run("ingest", mcap, "--mapping", mapping, "-o",
                                     root / "mcap.parquet", "-q"),
        "identify bag": run("identify", bag, "--output", "p", "--regressors",
                            "p[k-1..k-2],m1[k-1]", "-o", root / "RUN", "-q"),
        "report": run("report", root / "RUN"),
    }
    return {"printed": printed, "run": root / "RUN", "mcap_table": root / "mcap.parquet"}


def test_log_names_reach_no_terminal_raw(logs: dict[str, Any]) -> None:
    for command, text in logs["printed"].items():
        assert raw_in(text) == [], f"etsid {command} printed {raw_in(text)} raw"
    # the names arrived (escaped), so the check saw them
    for command in ("inspect bag", "inspect mcap", "inspect mcap --mapping"):
        assert SHOWN in logs["printed"][command], command
    assert "onerror" in logs["printed"]["inspect bag"]
    assert f"x{FIELD_PAYLOAD}" in logs["printed"]["inspect mcap --mapping"]
    assert "etsid-test <img" in logs["printed"]["inspect mcap"]  # the library string


def test_hostile_fields_are_read_as_their_values(logs: dict[str, Any]) -> None:
    from etsid.table import load_table

    table = load_table(logs["mcap_table"])
    assert (table["p"] == 1.0).all() and (table["q"] == 2.0).all()
    source = table.attrs["signals"]["p"]["source"]
    assert raw_in(source) == []
    assert source.endswith(f"x{FIELD_PAYLOAD}\\x1b]52;c;QUFBQQ==\\x07\\x9b31m\\u202e")


def test_log_names_in_report_md_are_inert(logs: dict[str, Any]) -> None:
    text = (logs["run"] / "report" / "report.md").read_text(encoding="utf-8")
    assert SHOWN in text, "the hostile topic never reached report.md: the test saw nothing"
    assert raw_in(text) == [] and live_markup(text) == []


def test_log_names_run_no_handler_on_hover(browser: Any, logs: dict[str, Any]) -> None:
    state = hover_everything(browser, logs["run"] / "report" / "index.html")
    assert_page_safe(state, "run page")
    config = next(p for p in state["pre"] if '"schema": "etsid.run/1"' in p)
    assert SHOWN in config and "onerror" in config  # the topic is shown, as text
    assert config.count("\n") > 20 and "\\x0a" not in config  # lines kept


# ---- vehicle files -----------------------------------------------------------------------

def _toml_text(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value)  # a TOML basic string: \uXXXX for every control character
    if isinstance(value, list):
        return "[" + ", ".join(_toml_text(v) for v in value) + "]"
    return repr(value)


def _vehicle_toml(data: dict[str, Any]) -> str:
    """``data`` (a parsed vehicle file) as TOML text; keys quoted."""
    lines = [f"{json.dumps(k)} = {_toml_text(v)}" for k, v in data.items()
             if not isinstance(v, dict)]
    for section, table in data.items():
        if isinstance(table, dict):
            lines.append(f"[{json.dumps(section)}]")
            lines += [f"{json.dumps(k)} = {_toml_text(v)}" for k, v in table.items()]
    return "\n".join(lines) + "\n"


BASE_VEHICLE = ROOT / "etsid" / "sim" / "vehicles" / "quad250.toml"


def _string_fields() -> list[tuple[str, str]]:
    """Every vehicle field whose value is text (name, choices, spin), from the one
    declaration of the vehicle's fields, and [effects] estimator."""
    from etsid.sim.vehicle_params import EFFECTS, VEHICLE

    fields = [(section, name) for section, params in VEHICLE.items()
              for name, p in params.items() if p.kind in ("str", "choice", "spin")]
    fields += [("effects", name) for name, p in EFFECTS.items() if p.kind in ("str", "choice")]
    return fields


def test_every_text_field_of_the_vehicle_is_listed() -> None:
    # the list the variants below walk holds what a vehicle file names in words
    assert {("", "name"), ("frame", "spin"), ("ground", "model"),
            ("effects", "estimator")} <= set(_string_fields())


def _variants() -> dict[str, dict[str, Any]]:
    """One vehicle file per text field (and description, an unknown key, a number) holding
    the hostile string."""
    base = tomllib.loads(BASE_VEHICLE.read_text(encoding="utf-8"))
    out: dict[str, dict[str, Any]] = {}
    for section, name in [*_string_fields(), ("", "description"), ("", "mass"),
                          ("", HOSTILE), ("inertia", "ixx")]:
        data = copy.deepcopy(base)
        table = data.setdefault(section, {}) if section else data
        old = table.get(name)
        table[name] = ([f"cw{HOSTILE}"] * len(old) if isinstance(old, list)
                       else f"{old}{HOSTILE}" if isinstance(old, str) else HOSTILE)
        out[f"{section}.{name}" if section else name] = data
    return out


VARIANTS = _variants()


@pytest.mark.parametrize("field", list(VARIANTS),
                         ids=[f.replace(HOSTILE, "HOSTILE") for f in VARIANTS])
def test_vehicle_text_fields_reach_no_terminal_raw(field: str, tmp_path: Path) -> None:
    vehicle = tmp_path / "v.toml"
    vehicle.write_text(_vehicle_toml(VARIANTS[field]), encoding="utf-8")
    code, printed = invoke("simulate", "hover-oge", "--vehicle", vehicle, "--duration", 2,
                           "--rate", 50, "-o", tmp_path / "x.parquet")
    assert raw_in(printed) == [], f"{field}: {raw_in(printed)} printed raw"
    lines = [ln for ln in printed.splitlines() if ln.startswith("etsid:")]
    if field in ("name", "description"):  # free text: the vehicle flies
        assert code == 0, printed
    else:  # one line naming the file and the field, the value shown escaped
        assert code == 1 and len(lines) == 1 and str(vehicle) in lines[0], printed
        assert "internal error" not in printed and SHOWN in lines[0], printed


@pytest.fixture(scope="module")
def vehicle(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """A vehicle named with markup and escapes: simulated (a table and a CSV with its
    sidecar), flown by the PID controller (a control run and its report) and given to gap."""
    root = tmp_path_factory.mktemp("vehicle")
    path = root / "hostile.toml"
    data = tomllib.loads(BASE_VEHICLE.read_text(encoding="utf-8"))
    data["name"] = "quad" + HOSTILE
    data["description"] = HOSTILE + " " + data["description"]
    path.write_text(_vehicle_toml(data), encoding="utf-8")
    control = root / "CONTROL"
    printed = {
        "simulate": run("simulate", "hover-oge", "--vehicle", path, "--duration", 3,
                        "--rate", 100, "-o", root / "sim.parquet"),
        "simulate csv": run("simulate", "hover-oge", "--vehicle", path, "--duration", 3,
                            "--rate", 100, "-o", root / "sim.csv"),
        "ingest csv": run("ingest", root / "sim.csv", "-o", root / "csv.parquet", "-q"),
        "control": run("control", "sine-altitude", "--duration", 8, "--controller", "pid",
                       "--vehicle", path, "-o", control),
        "gap": run("gap", SAMPLE, OTHER, "--vehicle", path, "--out", root / "GAP"),
    }
    return {"printed": printed, "control": control, "gap": root / "GAP", "root": root}


def test_vehicle_name_reaches_no_terminal_raw(vehicle: dict[str, Any]) -> None:
    for command, text in vehicle["printed"].items():
        assert raw_in(text) == [], f"etsid {command} printed {raw_in(text)} raw"
    assert SHOWN in vehicle["printed"]["simulate"]  # the name is shown, escaped
    sidecar = (vehicle["root"] / "sim.csv.attrs.json").read_text(encoding="utf-8")
    assert raw_in(json.loads(sidecar)["vehicle"]) == []


def test_vehicle_name_in_control_report_is_inert(browser: Any,
                                                  vehicle: dict[str, Any]) -> None:
    report = vehicle["control"] / "report"
    text = (report / "report.md").read_text(encoding="utf-8")
    assert raw_in(text) == [] and live_markup(text) == []
    state = hover_everything(browser, report / "index.html")
    assert_page_safe(state, "control page")
    config = next(p for p in state["pre"] if '"plant"' in p)
    assert SHOWN in config and "onerror" in config  # the name is shown, as text
    assert "\n" in config and "\\x0a" not in config


# ---- rule bases --------------------------------------------------------------------------

def _leaves(doc: Any, path: tuple[Any, ...] = ()) -> Iterator[tuple[Any, ...]]:
    """Paths of every string in ``doc``."""
    if isinstance(doc, dict):
        for key, value in doc.items():
            yield from _leaves(value, (*path, key))
    elif isinstance(doc, list):
        for i, value in enumerate(doc):
            yield from _leaves(value, (*path, i))
    elif isinstance(doc, str):
        yield path


def _at(doc: Any, path: tuple[Any, ...]) -> Any:
    for key in path:
        doc = doc[key]
    return doc


def _set(doc: Any, path: tuple[Any, ...], value: Any) -> None:
    _at(doc, path[:-1])[path[-1]] = value


def poison(doc: Any, schema: dict[str, Any]) -> tuple[Any, set[tuple[Any, ...]]]:
    """``doc`` with :data:`HOSTILE` appended to every string its ``schema`` lets hold any
    text (an enum, a constant or a pattern keeps its value), and the paths changed."""
    import jsonschema

    validator = jsonschema.validators.validator_for(schema)(schema)
    out, hit = copy.deepcopy(doc), set(_leaves(doc))
    for path in hit:
        _set(out, path, _at(doc, path) + HOSTILE)
    while True:
        refused: set[tuple[Any, ...]] = set()
        errors = list(validator.iter_errors(out))
        while errors:
            error = errors.pop()
            refused.add(tuple(error.absolute_path))
            errors.extend(error.context or [])
        refused &= hit
        if not refused:
            break
        for path in refused:
            _set(out, path, _at(doc, path))
        hit -= refused
    validator.validate(out)
    return out, hit


@pytest.fixture(scope="module")
def rules(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """A gas-furnace rule base with every free string hostile, and one with only the
    output's name hostile; each through ``rules``, ``rules --full`` and ``predict``."""
    from etsid.ets.serialize import SCHEMA_PATH

    root = tmp_path_factory.mktemp("rules")
    run("identify", GAS, "--output", "co2", "--regressors", "co2[k-1],input_gas_rate[k-4]",
        "-o", root / "RUN", "-q")
    doc = json.loads((root / "RUN" / "rules.json").read_text(encoding="utf-8"))
    every, hit = poison(doc, json.loads(SCHEMA_PATH.read_text(encoding="utf-8")))
    output = copy.deepcopy(doc)
    output["outputs"] = [name + HOSTILE for name in doc["outputs"]]
    output["regressors"]["outputs"] = output["outputs"]
    printed = {}
    for name, variant in (("every", every), ("output", output)):
        path = root / f"{name}.json"
        path.write_text(json.dumps(variant), encoding="utf-8")
        printed[f"rules {name}"] = invoke("rules", path)
        printed[f"rules --full {name}"] = invoke("rules", "--full", path)
        printed[f"predict {name}"] = invoke("predict", "--rules", path, GAS, "--out",
                                            root / f"P-{name}")
    return {"printed": printed, "hit": hit}


def test_rule_base_strings_reach_no_terminal_raw(rules: dict[str, Any]) -> None:
    assert {("outputs", 0), ("inputs", 0)} <= rules["hit"]  # names, not only free text
    for command, (code, text) in rules["printed"].items():
        assert raw_in(text) == [], f"etsid {command} printed {raw_in(text)} raw"
        assert "internal error" not in text and "Traceback" not in text, text
        lines = [ln for ln in text.splitlines() if ln.startswith("etsid:")]
        assert code == 0 or (code == 1 and len(lines) == 1), f"{command}: {text}"
    # the names arrived: `rules` prints the hostile output, escaped
    assert rules["printed"]["rules output"][0] == 0
    assert f"co2{PAYLOAD[:20]}" in rules["printed"]["rules output"][1]
    assert SHOWN in rules["printed"]["rules output"][1]


# ---- gap.json ----------------------------------------------------------------------------

@pytest.fixture(scope="module")
def gap(vehicle: dict[str, Any], tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """The gap folder of the hostile vehicle with every free string of gap.json made
    hostile (as a sender would), reported again."""
    from etsid.report.gap import GAP_SCHEMA_PATH

    folder = tmp_path_factory.mktemp("gap") / "GAP"
    folder.mkdir()
    for name in ("gap.json", "gap_series.parquet"):
        shutil.copy(vehicle["gap"] / name, folder / name)
    doc = json.loads((folder / "gap.json").read_text(encoding="utf-8"))
    schema = json.loads(GAP_SCHEMA_PATH.read_text(encoding="utf-8"))
    poisoned, hit = poison(doc, schema)
    (folder / "gap.json").write_text(json.dumps(poisoned), encoding="utf-8")
    return {"printed": run("report", folder), "folder": folder, "hit": hit}


def test_gap_json_strings_reach_no_terminal_raw(gap: dict[str, Any]) -> None:
    assert len(gap["hit"]) > 50, "too few strings of gap.json were made hostile"
    assert raw_in(gap["printed"]) == []


def test_gap_json_strings_in_report_md_are_inert(gap: dict[str, Any]) -> None:
    text = (gap["folder"] / "report.md").read_text(encoding="utf-8")
    assert SHOWN in text, "no hostile string of gap.json reached report.md"
    assert raw_in(text) == [] and live_markup(text) == []


def test_gap_json_strings_run_no_handler_on_hover(browser: Any, gap: dict[str, Any]) -> None:
    state = hover_everything(browser, gap["folder"] / "index.html")
    assert_page_safe(state, "gap page")
    assert SHOWN in state["text"] and "onerror" in state["text"]  # shown, as text
