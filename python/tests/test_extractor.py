"""``Extractor.run``: the same features as ``extract_log`` on every frame,
from any input form; clear errors for input it cannot take."""

import lms_features as lf
import numpy as np
import pytest

from conftest import log

FLOAT_FIELDS = {
    # LINE_DTYPE field -> where the JSON record has it
    "alpha": lambda l: l["alpha"],
    "r": lambda l: l["r"],
    "cov_aa": lambda l: l["cov"][0][0],
    "cov_ar": lambda l: l["cov"][0][1],
    "cov_rr": lambda l: l["cov"][1][1],
    "chi2": lambda l: l["chi2"],
    "x0": lambda l: l["endpoints"][0][0],
    "y0": lambda l: l["endpoints"][0][1],
    "x1": lambda l: l["endpoints"][1][0],
    "y1": lambda l: l["endpoints"][1][1],
}
CORNER_FLOATS = {
    "x": lambda c: c["x"],
    "y": lambda c: c["y"],
    "cov_xx": lambda c: c["cov"][0][0],
    "cov_xy": lambda c: c["cov"][0][1],
    "cov_yy": lambda c: c["cov"][1][1],
    "angle_deg": lambda c: c["angle_deg"],
}


def f32(values):
    """JSON numbers (None for null) as float32, null as NaN."""
    return np.array([np.nan if v is None else v for v in values], dtype=np.float64).astype(np.float32)


def same_bits(a, b):
    """float32 arrays equal bit for bit (NaN where both are NaN)."""
    return a.dtype == b.dtype == np.float32 and a.tobytes() == b.tobytes()


def assert_features_are_record(f, record):
    """Every feature of ``f`` (``Extractor.run``) is the record's (``extract_log``)."""
    where = f"frame {record['frame']}"
    lines, corners = record["lines"], record["corners"]
    assert len(f.lines) == len(lines), where
    for name, read in FLOAT_FIELDS.items():
        assert same_bits(f.lines[name], f32([read(l) for l in lines])), f"{where}: lines.{name}"
    for name in ("first", "last", "points"):
        assert f.lines[name].tolist() == [l[name] for l in lines], f"{where}: lines.{name}"
    assert len(f.corners) == len(corners), where
    for name, read in CORNER_FLOATS.items():
        assert same_bits(f.corners[name], f32([read(c) for c in corners])), f"{where}: corners.{name}"
    for name in ("well_conditioned", "line_a", "line_b"):
        assert f.corners[name].tolist() == [c[name] for c in corners], f"{where}: corners.{name}"
    assert [list(s) for s in f.segments.tolist()] == record["segments"], where
    assert f.edges.tolist() == record["edges"], where
    assert f.stats == record["stats"], where
    assert same_bits(f.smoothed, f32(record["smoothed"])), f"{where}: smoothed"
    d = f.mahalanobis.copy()
    d[~np.isfinite(d)] = np.nan
    assert same_bits(d, f32(record["mahalanobis"])), f"{where}: mahalanobis"


@pytest.mark.filterwarnings("ignore:.*fill values:UserWarning")
def test_run_on_every_frame_of_every_log_is_extract_log(every_log):
    records = lf.extract_log(every_log)
    ex = lf.Extractor(records.params)
    count = 0
    for count, (frame, record) in enumerate(zip(lf.read_log(every_log), records), start=1):
        assert frame.index == record["frame"]
        f = ex.run(frame.ranges, frame.resolution_deg, frame.fov_deg)
        assert_features_are_record(f, record)
    assert count > 0 and next(records, None) is None


def test_run_on_a_capture_is_extract_log(capture):
    ex = lf.Extractor()
    for frame, record in zip(lf.read_log(capture), lf.extract_log(capture)):
        assert (frame.n, frame.fov_deg, frame.resolution_deg) == (401, 100, 0.25)
        assert_features_are_record(ex.run(frame.ranges, resolution_deg=0.25, fov_deg=100), record)


def test_every_input_form_gives_the_same_features():
    path = log("intel")  # 180 beams at 1°: a CARMEN scan without its last beam
    frame = next(iter(lf.read_log(path)))
    ex = lf.Extractor(lf.Params.for_log(path))
    want = ex.run(frame)
    ranges = frame.ranges
    strided = np.repeat(ranges, 2)[::2]  # a view with a stride of 8 bytes
    assert not strided.flags.c_contiguous
    for form in (ranges, ranges.astype(np.float64), ranges.tolist(), tuple(ranges.tolist()), strided):
        got = ex.run(form, resolution_deg=1, fov_deg=180)
        for name in ("lines", "corners", "segments", "edges", "smoothed", "mahalanobis"):
            assert getattr(got, name).tobytes() == getattr(want, name).tobytes(), (type(form), name)
        assert got.stats == want.stats
    # 0 and +inf are beams without a range; both count as invalid.
    zeroed = ranges.copy()
    zeroed[np.isinf(zeroed)] = 0
    assert ex.run(zeroed, 1, 180).stats == want.stats
    assert want.stats["valid_beams"] == int(np.isfinite(ranges).sum())


def test_the_features_arrays():
    frame = next(iter(lf.read_log(log("csail"))))
    f = lf.Extractor(lf.Params(sigma=0.01)).run(frame)
    assert f.lines.dtype == lf.LINE_DTYPE and f.corners.dtype == lf.CORNER_DTYPE
    assert f.segments.dtype == lf.SEGMENT_DTYPE and f.edges.dtype == np.uint16
    assert list(f.stats) == [name for name, _ in lf.STATS]
    assert f.smoothed.shape == (361,) and f.mahalanobis.shape == (359,)
    assert np.isnan(f.smoothed[~frame.valid]).all() and not np.isnan(f.smoothed[frame.valid]).any()
    line = f.lines[0]
    # The end points lie on the line x·cos α + y·sin α = r.
    for x, y in ((line["x0"], line["y0"]), (line["x1"], line["y1"])):
        assert abs(x * np.cos(line["alpha"]) + y * np.sin(line["alpha"]) - line["r"]) < 1e-4
    f.lines["r"][0] = 0  # the arrays are the caller's: writable
    assert "lines=" in repr(f)


def scan(n=361, value=2.0):
    return np.full(n, value, dtype=np.float32)


@pytest.mark.parametrize(
    "ranges, kwargs, error, message",
    [
        (np.where(np.arange(361) == 17, np.nan, 2.0), {}, ValueError, r"ranges\[17\] is NaN"),
        (np.where(np.arange(361) == 3, -0.5, 2.0), {}, ValueError, r"ranges\[3\] is -0\.5"),
        (np.where(np.arange(361) == 5, -np.inf, 2.0), {}, ValueError, r"ranges\[5\] is -inf"),
        ([2.0] * 100 + [float("nan")] + [2.0] * 260, {}, ValueError, r"ranges\[100\] is NaN"),
        (scan(100), {}, ValueError, r"ranges has 100 values: a 180°/0\.5° scan has 361 \(or 360"),
        (scan(181), dict(resolution_deg=0.25, fov_deg=100), ValueError, r"has 181 values: a 100°/0\.25° scan has 401"),
        (scan(), dict(resolution_deg=0.3), ValueError, r"no LMS 2xx scan has a 180(\.0)?° field at 0\.3°"),
        (scan(), dict(fov_deg=90), ValueError, r"no LMS 2xx scan has a 90(\.0)?° field"),
        (scan(401), dict(resolution_deg=0.25, fov_deg=180), ValueError, r"no LMS 2xx scan"),
        (np.full(361, 2, dtype=np.int64), {}, TypeError, r"float32 or float64, not int64"),
        (np.full(361, 2, dtype=np.float16), {}, TypeError, r"float32 or float64, not float16"),
        (np.full((2, 361), 2.0), {}, ValueError, r"one-dimensional, not of shape \(2, 361\)"),
        ([2.0] * 200 + ["x"] + [2.0] * 160, {}, TypeError, r"ranges\[200\] is a str, not a number"),
        ("2.0 2.0", {}, TypeError, r"numpy array \(float32 or float64\) or a list"),
        (None, {}, TypeError, r"not NoneType"),
    ],
    ids=[
        "nan", "negative", "minus-inf", "nan-in-list", "length", "length-100-0.25",
        "resolution", "fov", "variant", "int64", "float16", "2-d", "str-in-list", "str", "none",
    ],
)
def test_bad_input_is_a_clear_error(ranges, kwargs, error, message):
    with pytest.raises(error, match=message):
        lf.Extractor().run(ranges, **kwargs)


def test_every_variant_runs():
    ex = lf.Extractor()
    for fov, res, n in ((180, 1, 181), (180, 0.5, 361), (100, 1, 101), (100, 0.5, 201), (100, 0.25, 401)):
        bearings = np.deg2rad(-fov / 2 + res * np.arange(n))
        ranges = np.where(np.abs(bearings) < 1.2, 3.0 / np.cos(bearings), 0.0)  # a wall 3 m ahead
        f = ex.run(ranges, resolution_deg=res, fov_deg=fov)
        assert len(f.lines) == 1, (fov, res)
        assert abs(f.lines["r"][0] - 3.0) < 1e-3 and abs(f.lines["alpha"][0]) < 1e-3
