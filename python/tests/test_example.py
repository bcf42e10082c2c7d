"""The plotting example of docs/PYTHON.md runs and writes a PNG."""

import subprocess
import sys
from pathlib import Path

import pytest

from conftest import log

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "plot_frame.py"


def test_plot_frame_writes_a_png(tmp_path):
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        pytest.fail("the example needs matplotlib: pip install matplotlib")
    out = tmp_path / "frame.png"
    run = subprocess.run(
        [sys.executable, str(EXAMPLE), str(log("csail")), str(out), "--frame", "74", "--set", "split_depth=4"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode == 0, run.stderr
    assert "frame 74," in run.stdout
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and out.stat().st_size > 10_000
