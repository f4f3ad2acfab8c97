"""The local pool's workers run the etsid of the calling process, wherever it is started."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import etsid

ROOT = Path(etsid.__file__).resolve().parents[1]

SCRIPT = """
import sys
from etsid.batch import BatchSpec, read_results, run_batch
from etsid.ingest import ReadOptions
if __name__ == "__main__":
    run_batch([sys.argv[1]], BatchSpec("inspect", read_options=ReadOptions()), sys.argv[2],
              jobs=2)
    row = read_results(sys.argv[2]).iloc[0]
    print(row["status"], row["format"])
"""


def test_workers_ignore_an_etsid_in_the_current_directory(fleet: Path, tmp_path: Path) -> None:
    """Python 3.11's fork server imports its preload modules with the current directory
    first on ``sys.path``: a decoy ``etsid`` there must not be what the workers run."""
    decoy = tmp_path / "cwd" / "etsid"
    decoy.mkdir(parents=True)
    marker = tmp_path / "decoy-imported"
    (decoy / "__init__.py").write_text(
        f"open({str(marker)!r}, 'w').write('x')\nraise ImportError('decoy')\n")
    script = tmp_path / "run.py"
    script.write_text(SCRIPT)
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    env.pop("PYTHONSAFEPATH", None)
    done = subprocess.run([sys.executable, str(script), str(fleet / "a.tlog"),
                           str(tmp_path / "out")], cwd=decoy.parent, env=env,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split() == ["ok", "tlog"]
    assert not marker.exists()
