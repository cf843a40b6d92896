"""Downstream closing the pipe (`gyrotest … | head -1`) is not an error: exit 0, nothing on
stderr. rich's console used to turn the BrokenPipeError into SystemExit(1)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

SAMPLE = Path(__file__).resolve().parent.parent / "sample_data"


def test_a_closed_pipe_downstream_exits_0():
    r, w = os.pipe()
    os.close(r)  # the reader is gone before the first write: every write meets a closed pipe
    try:
        p = subprocess.run([sys.executable, "-c", "from gyrotest.cli import main; main()",
                            "info", str(SAMPLE / "bias_run1.parquet"),
                            "--profile", str(SAMPLE / "bias_run1.profile.toml")],
                           stdout=w, stderr=subprocess.PIPE, timeout=120)
    finally:
        os.close(w)
    err = p.stderr.decode()
    assert p.returncode == 0, err
    assert "Traceback" not in err and "error" not in err.lower(), err
