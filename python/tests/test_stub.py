"""The type stub (``lms_features/__init__.pyi``) matches the module: mypy's
stubtest compares every name, signature and default with the runtime."""

import subprocess
import sys

import pytest


def test_stubtest_finds_no_difference(tmp_path):
    pytest.importorskip("mypy", reason="stubtest comes with mypy: pip install mypy")
    run = subprocess.run(
        [sys.executable, "-m", "mypy.stubtest", "--ignore-disjoint-bases", "lms_features"],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=tmp_path,  # mypy's cache goes there, not into the work tree
    )
    assert run.returncode == 0, run.stdout + run.stderr
