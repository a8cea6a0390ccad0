"""``dacm measure``: the response unit in the JSON key names, the numbers of the table, and
the loop CSV's declared schema (every other file is one line naming it)."""

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tests.conftest import assert_one_line_error
from tests.readout.test_measured import _synthetic


def test_json_names_the_units_as_the_text_does(tmp_path, dacm):
    loop = _synthetic(0.0)
    csv = tmp_path / "loop.csv"
    np.savetxt(csv, np.c_[loop.force_N, loop.response], delimiter=",",
               header="force_N,displacement_mm", comments="")
    res = json.loads(dacm("measure", csv, "--preset", "sample-b-as-cut", "--json")[1])
    assert set(res["measured"]) == {"kind", "max_force_N", "span_mm", "hysteresis_fraction",
                                    "sensitivity_mm_per_N", "nonlinearity_pct"}
    text = dacm("measure", csv, "--preset", "sample-b-as-cut")[1]
    row = next(line.split() for line in text.splitlines() if line.strip().startswith("sensitivity"))
    # the table prints 4 significant digits
    assert float(row[1]) == pytest.approx(res["measured"]["sensitivity_mm_per_N"], rel=1e-3)
    assert float(row[2]) == pytest.approx(res["model"]["sensitivity_mm_per_N"], rel=1e-3)


LOOP = [0, 1, 2, 3, 4, 3, 2, 1, 0]


def _loop_csv(path, header="force_N,displacement_mm", rows=None):
    rows = rows if rows is not None else [f"{f:g},{f / 4.4:g}" for f in LOOP]
    path.write_text("\n".join(([header] if header else []) + rows) + "\n")
    return path


@pytest.mark.parametrize("make, fragment", [
    (lambda p: _loop_csv(p, "force_N,displacement_mm,temperature_C",
                         [f"{f:g},{f / 4.4:g},21" for f in LOOP]), "the header has 3 columns"),
    (lambda p: _loop_csv(p, None, [f"{f:g},{f / 4.4:g},21" for f in LOOP]), "row 1 has 3 columns"),
    (lambda p: _loop_csv(p, "force_kN,displacement_mm"), "column 'force_kn': must be force in N"),
    (lambda p: _loop_csv(p, None, [f"{f * 1e300:g},{f:g}" for f in LOOP]), "is beyond +-10000 N"),
    (lambda p: _loop_csv(p, None, [f"{f:g},{f * 1e9:g}" for f in LOOP]), "is beyond +-1000 mm"),
    (lambda p: p.write_text("0," + "9" * 200_000 + "\n") and p, "field larger than field limit"),
    (lambda p: Path("/dev/zero"), "not a regular file"),
    (lambda p: p.parent, "is a folder"),
    (lambda p: p.parent / "none.csv", "no such file"),
])
def test_a_loop_outside_the_csv_schema_is_one_line_naming_the_file(tmp_path, dacm, make, fragment):
    path = make(tmp_path / "loop.csv")
    status, out, err = dacm("measure", path, "--preset", "basis", "--out", tmp_path / "out")
    assert_one_line_error(status, err, "measure")
    assert str(path) in err and fragment in err, err
    assert not (tmp_path / "out").exists()


def test_a_file_bigger_than_the_limit_is_refused_before_it_is_read(tmp_path, monkeypatch):
    import sensor.readout.measured as measured
    from sensor.errors import HysteresisError

    monkeypatch.setattr(measured, "MAX_BYTES", 100)
    path = _loop_csv(tmp_path / "loop.csv", rows=[f"{f:g},{f / 4.4:g}" for f in LOOP * 4])
    with monkeypatch.context() as m:
        m.setattr(Path, "open", lambda *a, **k: pytest.fail("the file was opened"))
        with pytest.raises(HysteresisError, match="bytes: at most 100 are read"):
            measured.read_loop_csv(path)


@settings(max_examples=40, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(columns=st.integers(1, 4), header=st.sampled_from(["", "force_N,displacement_mm",
                                                          "force [N],displacement [mm]", "a,b"]),
       values=st.lists(st.floats(allow_nan=True, allow_infinity=True, width=64), min_size=1, max_size=40))
def test_any_csv_is_a_loop_or_one_line(tmp_path_factory, capsys, columns, header, values):
    """Property over the schema's space (column count, header, any float): the reader either
    returns a loop of two finite columns within the limits, or raises one HysteresisError
    naming the file; the CLI then says it in one line."""
    from sensor.errors import HysteresisError
    from sensor.readout.measured import VALUE_LIMITS, read_loop_csv

    path = tmp_path_factory.mktemp("csv") / "loop.csv"
    rows = [",".join(repr(v) for v in values[i:i + columns]) for i in range(0, len(values), columns)]
    path.write_text("\n".join(([header] if header else []) + rows) + "\n")
    try:
        loop = read_loop_csv(path)
    except HysteresisError as exc:
        assert str(path) in str(exc) and "\n" not in str(exc)
        return
    assert np.isfinite(loop.force_N).all() and np.isfinite(loop.response).all()
    assert (np.abs(loop.force_N) <= VALUE_LIMITS["force"][0]).all()
    assert columns == 2
