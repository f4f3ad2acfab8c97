"""The README's examples are true: the Python snippet runs and the commands name real files."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
README = (ROOT / "README.md").read_text()


def test_python_example_runs(monkeypatch: pytest.MonkeyPatch,
                             capsys: pytest.CaptureFixture[str]) -> None:
    snippet = re.search(r"```python\n(.*?)```", README, re.S)
    assert snippet is not None
    monkeypatch.chdir(ROOT)
    exec(compile(snippet.group(1), "README.md", "exec"), {})
    out = capsys.readouterr().out
    assert "IF p ≈" in out and "THEN p+ =" in out


def test_first_commands_name_existing_sample_logs() -> None:
    shell = re.findall(r"```sh\n(.*?)```", README, re.S)
    assert len(shell) >= 2, "README opens with two commands"
    logs = re.findall(r"sample_logs/\S+", shell[0])
    assert logs and all((ROOT / log).exists() for log in logs)
    assert "etsid identify" in shell[0] and "etsid report" in shell[0]
    assert "pytest" in shell[1]
    assert "python -m pytest" in (ROOT / ".ci" / "run").read_text()
