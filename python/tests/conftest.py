"""Shared fixtures: the built CLI, the shared logs, a capture recorded by
``host-bridge scan`` from ``host-bridge simulate``.

``HOST_BRIDGE`` names the CLI binary (default ``target/release/host-bridge``
of the repository: ``cargo build --release -p host-bridge``);
``LMS_DATA_DIR`` the shared data (default ``../shared/data`` beside the
repository), whose ``carmen/*.log.gz`` are the recorded logs.
"""

import os
import subprocess
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
HOST_BRIDGE = Path(os.environ.get("HOST_BRIDGE", REPO / "target" / "release" / "host-bridge"))
DATA = Path(os.environ.get("LMS_DATA_DIR", REPO.parent / "shared" / "data"))
LOGS = sorted((DATA / "carmen").glob("*.log.gz"))


def log_id(path):
    """A log's short name for test ids: ``csail`` for ``csail-corrected.log.gz``."""
    return path.name.replace("-corrected.log.gz", "")


def host_bridge():
    """The CLI binary, or a failure that says how to build it."""
    if not HOST_BRIDGE.is_file():
        pytest.fail(
            f"no host-bridge at {HOST_BRIDGE}: build it with `cargo build --release "
            "-p host-bridge` or set HOST_BRIDGE"
        )
    return str(HOST_BRIDGE)


def log(name):
    """The shared log ``carmen/NAME-corrected.log.gz``."""
    path = DATA / "carmen" / f"{name}-corrected.log.gz"
    if not path.is_file():
        pytest.fail(f"no {path}: set LMS_DATA_DIR to the shared data")
    return path


def pytest_generate_tests(metafunc):
    """``every_log``: each shared log, by its short name."""
    if "every_log" in metafunc.fixturenames:
        if not LOGS:
            pytest.fail(f"no logs in {DATA / 'carmen'}: set LMS_DATA_DIR to the shared data")
        metafunc.parametrize("every_log", LOGS, ids=[log_id(p) for p in LOGS])


@pytest.fixture(scope="session")
def capture(tmp_path_factory):
    """A capture of 6 scans at 100°/0.25° (mm), recorded by ``host-bridge
    scan`` from ``host-bridge simulate``'s room."""
    exe = host_bridge()
    where = tmp_path_factory.mktemp("capture")
    link, out = where / "lms", where / "room.lmscap"
    sim = subprocess.Popen(
        [exe, "simulate", "--link", str(link), "--count", "5"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    try:
        deadline = time.monotonic() + 20
        while not link.exists():
            if sim.poll() is not None or time.monotonic() > deadline:
                pytest.fail(f"host-bridge simulate did not start: {sim.stderr.read()!r}")
            time.sleep(0.02)
        subprocess.run(
            [exe, "scan", "--port", str(link), "--scans", "6", "--variant", "100/0.25", "-o", str(out)],
            check=True,
            capture_output=True,
            timeout=60,
        )
    finally:
        sim.terminate()
        sim.wait(timeout=20)
    return out


def cli_extract(path, *args):
    """Run ``host-bridge extract PATH ARGS…``: its records (``json.loads`` of
    each line, streamed) and, once they are read, its stderr lines through
    ``stderr`` (a list filled when the process ends)."""
    import json

    proc = subprocess.Popen(
        [host_bridge(), "extract", str(path), *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    stderr = []

    def records():
        with proc, proc.stdout, proc.stderr:
            for line in proc.stdout:
                yield json.loads(line)
            stderr.extend(proc.stderr.read().splitlines())
        assert proc.returncode == 0, "\n".join(stderr)

    return records(), stderr


def first_difference(got, want, at="record"):
    """Where ``got`` and ``want`` first differ (``None`` if equal): the path
    of keys and indices, with both values; floats compare exactly."""
    if type(got) is not type(want):
        return f"{at}: {got!r} ({type(got).__name__}) != {want!r} ({type(want).__name__})"
    if isinstance(got, dict):
        if list(got) != list(want):
            return f"{at}: keys {list(got)} != {list(want)}"
        for k in got:
            d = first_difference(got[k], want[k], f"{at}[{k!r}]")
            if d:
                return d
        return None
    if isinstance(got, list):
        if len(got) != len(want):
            return f"{at}: {len(got)} items != {len(want)}"
        for i, (g, w) in enumerate(zip(got, want)):
            d = first_difference(g, w, f"{at}[{i}]")
            if d:
                return d
        return None
    return None if got == want else f"{at}: {got!r} != {want!r}"
