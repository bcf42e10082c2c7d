"""``extract_log`` gives, frame for frame, the JSON object of ``host-bridge
extract``: same keys in the same order, same values, floats exactly."""

import warnings

import lms_features as lf
import pytest

from conftest import cli_extract, first_difference, log


def compare(path, ours, theirs):
    """Every frame of both equal; the frame count."""
    count = 0
    for count, (got, want) in enumerate(zip(ours, theirs), start=1):
        d = first_difference(got, want)
        assert d is None, f"{path.name}, frame {want['frame']}: {d}"
    # Both ended together.
    assert next(ours, None) is None and next(theirs, None) is None, f"{path.name}: frame counts differ"
    return count


def test_every_frame_of_every_log_is_extracts_json(every_log):
    theirs, stderr = cli_extract(every_log)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ours = lf.extract_log(every_log)
        count = compare(every_log, ours, theirs)
    assert count > 0
    # Each warning of extract (fill values caught by max_range) is ours too.
    cli_warnings = [line.split("warning: ", 1)[1] for line in stderr if "warning: " in line]
    ours = [str(w.message) for w in caught if w.category is UserWarning]
    assert ours == cli_warnings
    summary = stderr[-1]
    assert f": {count} frames," in summary, summary


def test_a_preset_and_settings_as_the_cli_gives_them():
    path = log("orebro")
    params = lf.Params.for_log(path, preset="paper", split_depth=2, tau=12)
    assert (params.split_depth, params.tau, params.fit_shared_points) == (2, 12.0, True)
    theirs, _ = cli_extract(path, "--preset", "paper", "--set", "split_depth=2", "--set", "tau=12")
    assert compare(path, lf.extract_log(path, params), theirs) == 237


def test_a_capture_is_extracted_as_the_cli_does(capture):
    theirs, _ = cli_extract(capture)
    records = lf.extract_log(capture)
    assert records.params == lf.Params()
    assert compare(capture, records, theirs) == 6


def test_data_defaults_of_the_logs():
    # cm logs: sigma 1 cm; the Acapulco log's fill values: max_range 50 m.
    assert lf.extract_log(log("csail")).params == lf.Params(sigma=0.01)
    with pytest.warns(UserWarning, match="fill values"):
        assert lf.Params.for_log(log("acapulco")).max_range == 50.0
    # The mm log: sigma 5 mm, the 32 m mode's largest range.
    orebro = lf.Params.for_log(log("orebro"))
    assert orebro.sigma == 0.005 and orebro.max_range < 33


def test_records_carry_float32_values_as_printed():
    import numpy as np

    record = next(lf.extract_log(log("csail")))
    line = record["lines"][0]
    assert list(line) == ["alpha", "r", "cov", "first", "last", "points", "chi2", "endpoints"]
    alpha = line["alpha"]
    assert isinstance(alpha, float)
    # The shortest decimal of the float32: repr is short, and float32 exact.
    assert float(str(np.float32(alpha))) == alpha
    assert list(record["stats"]) == [name for name, _ in lf.STATS]
    assert record["pose"] == list(next(lf.read_log(log("csail"))).pose)
