"""``read_log``: every input ``host-bridge`` reads (CARMEN logs gzip or
plain, captures), with the CLI's errors and warnings."""

import gzip

import lms_features as lf
import numpy as np
import pytest

from conftest import log

# The shared data's README: beams, resolution, frames.
TABLE = {
    "csail": (361, 0.5, 406),
    "belgioioso": (361, 0.5, 395),
    "intel": (180, 1.0, 910),
    "freiburg-campus": (360, 0.5, 2008),
    "orebro": (181, 1.0, 237),
    "freiburg-101": (360, 0.5, 292),
    "acapulco": (181, 1.0, 861),
}


@pytest.mark.parametrize("name", TABLE)
def test_the_logs_frames(name):
    n, resolution, frames = TABLE[name]
    count = 0
    for count, frame in enumerate(lf.read_log(log(name)), start=1):
        assert frame.index == count - 1
        assert (frame.n, len(frame), frame.resolution_deg, frame.fov_deg) == (n, n, resolution, 180)
    assert count == frames


def test_a_frame():
    reader = lf.read_log(log("csail"))
    assert "CARMEN log, cm ranges" in reader.source
    frame = next(reader)
    assert frame.ranges.dtype == np.float32 and frame.ranges.shape == (361,)
    assert (np.isinf(frame.ranges) == ~frame.valid).all()
    assert frame.invalid[0] == "no echo / not valid" and set(frame.invalid) == set(np.flatnonzero(~frame.valid))
    assert frame.bearings[0] == np.float32(-np.pi / 2) and abs(frame.bearings[180]) < 1e-6
    assert frame.pose == (0.154, 0.068, 0.562729) and frame.line is not None and frame.time_us is None
    assert "index=0" in repr(frame)


def test_a_plain_log_reads_as_its_gzip(tmp_path):
    plain = tmp_path / "intel.log"
    with gzip.open(log("intel"), "rb") as src:
        plain.write_bytes(src.read())
    for a, b in zip(lf.read_log(plain), lf.read_log(log("intel"))):
        assert a.ranges.tobytes() == b.ranges.tobytes() and a.pose == b.pose
    assert next(lf.extract_log(plain)) == next(lf.extract_log(log("intel")))


def test_a_capture(capture):
    frames = list(lf.read_log(capture))
    assert len(frames) == 6 and "capture" in lf.read_log(capture).source
    for i, f in enumerate(frames):
        assert (f.index, f.n, f.fov_deg, f.resolution_deg, f.pose, f.line) == (i, 401, 100, 0.25, None, None)
        assert f.time_us is not None
    assert [f.time_us for f in frames] == sorted(f.time_us for f in frames)


def lines_of(path, count):
    """The first ``count`` FLASER lines of a log, and the lines before them."""
    out, scans = [], 0
    with gzip.open(path, "rt") as src:
        for line in src:
            out.append(line)
            scans += line.startswith("FLASER")
            if scans == count:
                return out
    return out


def test_errors_and_warnings(tmp_path):
    with pytest.raises(FileNotFoundError, match="cannot open .*no-such.log"):
        lf.read_log(tmp_path / "no-such.log")
    with pytest.raises(IsADirectoryError, match="is a directory"):
        lf.read_log(tmp_path)
    empty = tmp_path / "empty.log"
    empty.write_text("")
    with pytest.raises(ValueError, match="is empty: no scans"):
        lf.read_log(empty)
    text = tmp_path / "notes.log"
    text.write_text("PARAM a 1\nODOM 0 0 0\n")
    with pytest.raises(ValueError, match="holds no scans: none of its 2 lines is a FLASER line"):
        list(lf.read_log(text))
    with pytest.raises(ValueError, match="unit `km`"):
        lf.read_log(log("csail"), unit="km")

    # A damaged scan: the unit's decision (a first pass) stops at it; with
    # the unit given, the scans before it, then the error naming the beam.
    lines = lines_of(log("csail"), 3)
    words = lines[-1].split(" ")
    words[2 + 7] = "-1.5"
    damaged = tmp_path / "damaged.log"
    damaged.write_text("".join(lines[:-1]) + " ".join(words))
    with pytest.raises(ValueError, match="line 196: negative range -1.5 for beam 7"):
        lf.read_log(damaged)
    reader = lf.read_log(damaged, unit="cm")
    assert [f.index for f in (next(reader), next(reader))] == [0, 1]
    with pytest.raises(ValueError, match="negative range -1.5 for beam 7"):
        next(reader)
    with pytest.raises(StopIteration):
        next(reader)

    # A file cut in its last line: the complete scans, and a warning.
    cut = tmp_path / "cut.log"
    cut.write_text("".join(lines)[:-40])
    with pytest.warns(UserWarning, match="the 2 complete scans before it are used"):
        assert len(list(lf.read_log(cut))) == 2
