"""``dacm measure --json``: the response unit in the key names, the numbers of the table."""

import json

import numpy as np
import pytest

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
