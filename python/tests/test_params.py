"""``Params``: the presets and parameters of the CLI, by the core's names;
errors that name the parameter."""

import ast
import math
import pickle
from pathlib import Path

import lms_features as lf
import pytest

NAMES = [name for name, _, _ in lf.PARAMETERS]


def test_the_table_is_the_cores():
    assert len(NAMES) == 33 and NAMES[:4] == ["sigma", "q", "iterations", "tau"]
    assert set(lf.PRESETS) == {"default", "v3.2", "v3.1", "v3.0", "v2", "paper"}
    for name, unit, meaning in lf.PARAMETERS:
        assert unit and meaning, name
    assert list(lf.Params().to_dict()) == NAMES
    assert set(NAMES) <= set(dir(lf.Params()))


def test_defaults_and_presets():
    p = lf.Params()
    assert (p.sigma, p.q, p.iterations, p.tau, p.min_points) == (0.005, 0.0, 5, 12.0, 5)
    assert (p.max_range, p.merge, p.split_depth) == (81.83, True, 8)
    assert lf.Params(preset="default") == p
    v3_2 = lf.Params(preset="v3.2")
    assert p.footprint_choice and not v3_2.footprint_choice
    assert v3_2.replace(footprint_choice=True) == p
    v3_1 = lf.Params(preset="v3.1")
    assert (v3_1.iterations, v3_1.tau) == (30, 9.0)
    assert v3_1.replace(iterations=5, tau=12) == v3_2
    assert p.merge_own_beams and not lf.Params(preset="v3.0").merge_own_beams
    assert lf.Params(preset="v3.0").replace(merge_own_beams=True) == v3_1
    paper = lf.Params(preset="paper")
    assert (paper.split_depth, paper.fit_shared_points, paper.max_range) == (0, True, math.inf)
    v2 = lf.Params(preset="v2")
    assert (v2.split_depth, v2.same_turn_windows, v2.merge_anchor_gate) == (8, False, math.inf)
    assert len({p, paper, v2}) == 3


def test_settings_read_as_the_cli_reads_them():
    p = lf.Params(preset="paper", sigma=0.01, split_depth=3, merge=False, max_range=float("inf"))
    assert (p.sigma, p.split_depth, p.merge, p.max_range) == (0.01, 3, False, math.inf)
    # Text as --set NAME=VALUE takes it, numpy scalars as numbers.
    np = pytest.importorskip("numpy")
    assert lf.Params(max_range="inf", merge="false", tau=np.float64(12), min_points=np.int64(7)) == lf.Params(
        max_range=math.inf, merge=False, tau=12, min_points=7
    )
    assert p.replace(sigma=0.02) == lf.Params(preset="paper", sigma=0.02, split_depth=3, merge=False)
    assert p.replace() == p


@pytest.mark.parametrize(
    "settings, message",
    [
        (dict(sigma=-1), "sigma must be finite and > 0"),
        (dict(sigma=float("nan")), "sigma must be a number"),
        (dict(iterations=0), "iterations must be between 1 and 1000"),
        (dict(iterations=2.5), "iterations must be a whole number"),
        (dict(split_depth=300), "split_depth must be a whole number 0..=255"),
        (dict(split_depth=17), "split_depth must be at most 16"),
        (dict(min_points=2), "min_points must be at least 3"),
        (dict(merge="yes"), "merge must be true or false"),
        (dict(min_corner_angle_deg=91), "min_corner_angle_deg must be between 0 and 90"),
        (dict(arc_chain=1), "arc_chain must be 0"),
        (dict(max_rang=50), "no parameter `max_rang`"),
    ],
)
def test_a_bad_value_or_name_is_a_value_error_naming_it(settings, message):
    with pytest.raises(ValueError, match=message):
        lf.Params(**settings)
    with pytest.raises(ValueError, match=message):
        lf.Params().replace(**settings)


def test_other_errors():
    with pytest.raises(ValueError, match="no preset `v1`: give one of default, v3.2, v3.1, v3.0, v2, paper"):
        lf.Params(preset="v1")
    with pytest.raises(TypeError, match="sigma: a number, a bool or text, not list"):
        lf.Params(sigma=[0.01])
    p = lf.Params()
    with pytest.raises(AttributeError, match="no parameter `sigm`"):
        p.sigm
    with pytest.raises(AttributeError, match=r"immutable: use params.replace\(sigma=...\)"):
        p.sigma = 0.01
    with pytest.raises(ValueError, match="no parameter `split-depth`; did you mean split_depth"):
        lf.Params(**{"split-depth": 2})


def test_repr_pickle_and_values_round_trip():
    for p in (lf.Params(), lf.Params(sigma=0.01, max_range=50), lf.Params(preset="paper", tau=12)):
        assert eval(repr(p), {"Params": lf.Params}) == p
        assert pickle.loads(pickle.dumps(p)) == p
        assert lf.Params(**p.to_dict()) == p
    assert repr(lf.Params(preset="paper", tau=12)) == "Params(preset='paper', tau=12.0)"
    assert repr(lf.Params(sigma=0.01)) == "Params(sigma=0.01)"


def test_extractor_keeps_its_params():
    p = lf.Params(sigma=0.01)
    assert lf.Extractor(p).params == p
    assert lf.Extractor().params == lf.Params()
    with pytest.raises(TypeError):
        lf.Extractor(params={"sigma": 0.01})


def test_the_type_stub_lists_every_parameter():
    stub = Path(lf.__file__).with_name("__init__.pyi")
    tree = ast.parse(stub.read_text())
    params = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == "Params")
    annotated = [n.target.id for n in params.body if isinstance(n, ast.AnnAssign)]
    assert annotated == NAMES
    assert (stub.parent / "py.typed").is_file()
