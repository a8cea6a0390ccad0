"""Property-based tests of every input parser and public constructor of the reliability
layer: whatever the input, the result is either a valid object or the package's own
specific error (never a TypeError, KeyError, OverflowError, MemoryError...)."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from geometry.errors import GeometryError
from geometry.params import FIELD_RULES, Design, design_from_dict, load_design, preset
from geometry.topology import build_beam_model, model_from_dict, model_to_dict
from geometry.validation import Number, is_stem
from sensor.design_space.spec import Grid, SweepSpec
from sensor.errors import SensorInputError, SweepError
from sensor.mechanics.hysteresis import StrainEnergyLaw

SETTINGS = settings(max_examples=150, deadline=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture])

#: Values a careless or hostile TOML/JSON file can hold.
SCALARS = st.one_of(st.none(), st.booleans(), st.integers(-10**30, 10**30),
                    st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=12),
                    st.sampled_from([np.float64(20.0), np.int64(3), np.float32(0.5), "05-03",
                                     "delrin", "..", "../x", "", "basis"]))
VALUES = st.recursive(SCALARS, lambda inner: st.one_of(st.lists(inner, max_size=13),
                                                         st.dictionaries(st.text(max_size=8), inner, max_size=4)),
                      max_leaves=20)
DESIGN_KEYS = st.sampled_from(sorted(FIELD_RULES) + ["hinge_set", "hinge_thickness_mm", "material",
                                                      "name", "body", "wingspan"])


@SETTINGS
@given(st.dictionaries(DESIGN_KEYS, VALUES, max_size=6))
def test_design_from_any_dict_is_a_design_or_a_parameter_error(data):
    try:
        d = design_from_dict(data)
    except GeometryError:
        return
    assert isinstance(d, Design) and is_stem(d.name)
    for name, rule in FIELD_RULES.items():
        assert getattr(d, name) is None or rule.ok(getattr(d, name))


@SETTINGS
@given(st.binary(max_size=200))
def test_any_bytes_as_a_design_toml(tmp_path, blob):
    path = tmp_path / "d.toml"
    path.write_bytes(blob)
    try:
        assert isinstance(load_design(path), Design)
    except GeometryError:
        pass


GOOD_MODEL = model_to_dict(build_beam_model(preset("basis")))


def _paths(obj, prefix=()):
    yield prefix
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            yield from _paths(v, prefix + (i,))


MODEL_PATHS = [p for p in _paths(GOOD_MODEL) if p]


@SETTINGS
@given(st.lists(st.tuples(st.sampled_from(MODEL_PATHS), VALUES), min_size=1, max_size=3))
def test_beam_model_with_any_field_replaced(changes):
    data = copy.deepcopy(GOOD_MODEL)
    for path, value in changes:
        target = data
        try:
            for key in path[:-1]:
                target = target[key]
            target[path[-1]] = value
        except (KeyError, IndexError, TypeError):  # an earlier change removed the path
            continue
    try:
        m = model_from_dict(data)
    except GeometryError:
        return
    assert np.isfinite(m.nodes).all() and (m.lengths_mm > 0).all() and m.E_MPa > 0


@SETTINGS
@given(VALUES)
def test_beam_model_from_any_value(value):
    with pytest.raises(GeometryError):
        model_from_dict(value)


@SETTINGS
@given(st.one_of(st.text(max_size=30), st.from_regex(r"-?[0-9.e+]{0,6}:-?[0-9.e+]{0,6}:-?[0-9e]{0,10}",
                                                     fullmatch=True)))
def test_grid_from_any_text(text):
    try:
        g = Grid.parse(text, "--phi1")
    except SweepError:
        return
    assert 1 <= g.n <= 2000 and 0 < g.start <= g.stop < 90


SPEC_FIELDS = st.fixed_dictionaries({}, optional={
    "hinge_sets": st.one_of(VALUES, st.lists(st.sampled_from(["05-03", "03-03"]), max_size=2).map(tuple)),
    "target_output_mm": SCALARS, "monte_carlo": SCALARS, "hinge_sd_mm": SCALARS,
    "seed": SCALARS, "base": VALUES,
    "phi1": st.one_of(SCALARS, st.tuples(st.floats(1, 44), st.floats(45, 89)).map(lambda t: Grid(*t, 3))),
})


@SETTINGS
@given(SPEC_FIELDS)
def test_sweep_spec_from_any_fields(fields):
    try:
        spec = SweepSpec(**fields)
    except SensorInputError:
        return
    assert spec.seed >= 0 and spec.monte_carlo >= 0 and math.isfinite(spec.hinge_sd_mm)
    assert type(spec.seed) is int and spec.to_json()


@SETTINGS
@given(SCALARS, SCALARS)
def test_strain_energy_law_from_anything(h, se):
    try:
        law = StrainEnergyLaw(h, "basis")
        value = law.predict(se)
    except SensorInputError:
        return
    assert law.h_per_mJ >= 0 and (np.isnan(value) or value >= 0)


@SETTINGS
@given(st.one_of(st.none(), st.floats(-5, 5)), st.one_of(st.none(), st.floats(-5, 5)),
       st.booleans(), st.booleans(), st.booleans(), SCALARS)
def test_number_rule_accepts_exactly_what_it_says(lo, hi, lo_open, hi_open, integer, value):
    rule = Number(lo, hi, lo_open=lo_open, hi_open=hi_open, integer=integer)
    try:
        v = rule.check("x", value, SensorInputError)
    except SensorInputError as exc:
        assert str(exc).startswith("x = ") and rule.rule in str(exc)
        return
    assert math.isfinite(v) and (lo is None or v >= lo) and (hi is None or v <= hi)
    assert not isinstance(value, bool)


# --- the named cases of the issue -------------------------------------------------------------

def test_sweep_spec_refuses_a_negative_seed_at_construction():
    with pytest.raises(SweepError, match=r"seed = -1: must be an integer in \[0, "):
        SweepSpec(seed=-1)


def test_numpy_scalars_are_the_numbers_they_hold():
    d = Design(phi1_deg=np.float32(20.0), phi2_deg=np.float64(30.0), kerf_mm=np.float16(0.5))
    assert d.phi1_deg == 20.0
    spec = SweepSpec(seed=np.int64(3), monte_carlo=np.int32(2), hinge_sd_mm=np.float32(0.02),
                     phi1=Grid(np.float64(10), np.int64(20), np.int64(3)))
    assert type(spec.seed) is int and spec.to_json() == SweepSpec(
        seed=3, monte_carlo=2, hinge_sd_mm=float(np.float32(0.02)), phi1=Grid(10.0, 20, 3)).to_json()
    assert StrainEnergyLaw(np.float64(0.06), "basis").predict(np.float32(1.0)) == pytest.approx(0.06)


def test_strain_energy_law_refuses_a_negative_strain_energy():
    law = StrainEnergyLaw.calibrate("basis")
    with pytest.raises(SensorInputError, match=r"strain_energy_mJ = -0.5: must be a number in \[0, 1e6\]"):
        law.predict([1.0, -0.5])
    assert np.isnan(law.predict(np.nan))  # NaN marks a failed solve: passed through


def test_design_name_cannot_leave_the_output_folder():
    for name in ("../escaped", "", ".hidden", "a/b", "..", "a\\b"):
        with pytest.raises(GeometryError, match="name = "):
            Design(name=name)
    assert Design(name="sample-a_2.v1").name == "sample-a_2.v1"


def test_a_proposed_body_without_phi2_is_an_error_not_the_basis():
    with pytest.raises(GeometryError, match="phi2_deg is missing"):
        design_from_dict({"phi1_deg": 20.0})
    assert design_from_dict({"phi1_deg": 20.0, "body": "basis"}).is_basis
