"""Equal range in the sweep: the resolution shortcut against the full sensor model, the
basis family's interpolation against a direct solve, the linear-limit strain-energy
relation, the (range, H) front and the CF attributes of the dataset."""

import math

import numpy as np
import pytest

from geometry.params import make_design, preset
from geometry.topology import build_beam_model
from sensor.design_space.dataset import load_dataset, save_dataset
from sensor.design_space.equal_range import answer_at, basis_at_range, pareto_front
from sensor.design_space.execution import run_sweep
from sensor.design_space.resolution import resolution_N
from sensor.design_space.spec import Grid, SweepSpec
from sensor.mechanics.qualifiers import qualify
from sensor.mechanics.solver import solve
from sensor.readout.datasheet import datasheet
from sensor.readout.sensor_model import build_sensor

SPEC = SweepSpec(phi1=Grid(18, 32, 5), phi2=Grid(12, 40, 6))


@pytest.fixture(scope="module")
def sweep():
    return run_sweep(SPEC, "test", workers=1)[0]


@pytest.mark.parametrize("name", ["basis", "sample-a", "sample-b"])
def test_resolution_from_the_solve_curve_matches_the_datasheet(name):
    """Second method: the datasheet of the full sensor model (20-increment solve, a
    201-point calibration cycle with hysteresis, its spline's slope). The sweep's shortcut
    reads the 4-increment solve curve; 2.5 % covers that curve's coarser slope (measured
    0.5-2.1 %)."""
    d = preset(name)
    r = solve(build_beam_model(d), 1.0)
    ours = resolution_N(r.force_N, r.output_mm, d.fiber_clearance_mm)
    assert ours == pytest.approx(datasheet(build_sensor(d)).resolution_N, rel=0.025)


def test_linear_limit_strain_energy_is_k_out_x_squared_over_2A():
    """In the linear limit the input work F x_in / 2 is the strain energy, F = k_out x_out
    and x_in = x_out / A, so SE = k_out x_out^2 / (2 A) for any body; the tool's SE is summed
    over its members, independently of A and k_out. At 0.005 mm travel the nonlinearity is
    about 1e-3 of the values, so 0.5 %."""
    x = 0.005
    for d in (make_design(22, None), make_design(22, 17.2), make_design(28, 13, "03-03")):
        q = qualify(solve(build_beam_model(d), x))
        assert q.strain_energy_mJ == pytest.approx(q.k_out_N_per_mm * x**2 / (2 * q.amplification), rel=5e-3)


def test_at_equal_range_the_dacm_needs_A_times_less_strain_energy_in_the_linear_limit():
    """A DACM and a basis body scaled to the same k_out (its hinges 1-8 thickened until
    its range matches): SE_dacm / SE_basis = A_basis / A_dacm within 0.5 %."""
    from sensor.design_space.optimise import DesignProblem, scale_to_range

    x = 0.005
    dacm = qualify(solve(build_beam_model(make_design(24, 20)), x))
    problem = DesignProblem(dacm.range_N, travel_mm=x, body="basis", pairs=(make_design(24, None).used_hinges,))
    basis = problem.design(scale_to_range(problem, np.array([[24.0, np.log(0.5)]]))[0])
    qb = qualify(solve(build_beam_model(basis), x))
    assert qb.range_N == pytest.approx(dacm.range_N, rel=2e-3)
    assert dacm.strain_energy_mJ / qb.strain_energy_mJ == pytest.approx(qb.amplification / dacm.amplification,
                                                                        rel=5e-3)


def test_family_interpolation_matches_a_direct_solve(sweep):
    """The best basis body of a range (log-log interpolation between family thicknesses)
    solved directly at its interpolated thickness: range and H within 0.5 %."""
    spec = SPEC
    for r in (1.0, 2.5, 4.0):
        b = basis_at_range(sweep, r)
        d = spec.family_design(b["phi1_deg"], b["hinge_mm"])
        q = qualify(solve(build_beam_model(d), 1.0))
        assert q.range_N == pytest.approx(r, rel=5e-3)
        assert q.hysteresis == pytest.approx(float(b["hysteresis"]), rel=5e-3)


def test_basis_family_contains_the_hinge_set_basis(sweep):
    """The 03-03 basis body (hinges 0.3 mm) lies on the family's curve at its phi1."""
    i = 2
    br = float(sweep["basis_range_N"].sel(hinges="03-03").values[i])
    fam = sweep["family_range_N"].values[i]
    t = sweep["family_hinge_mm"].values
    assert np.interp(np.log(0.3), np.log(t), np.log(fam)) == pytest.approx(math.log(br), abs=5e-3)


def test_front_has_the_lowest_H_within_the_tolerance(sweep):
    for h in ("05-03", "03-03"):
        front = pareto_front(sweep, h)
        ok = sweep["feasible"].sel(hinges=h).values & (sweep["stress_utilisation"].sel(hinges=h).values <= 1)
        r, H = sweep["range_N"].sel(hinges=h).values[ok], sweep["hysteresis"].sel(hinges=h).values[ok]
        assert len(front) >= 3
        for fr, fh in zip(front["range_N"], front["hysteresis"]):
            assert fh <= H[np.abs(r / fr - 1) <= 0.02].min()


def test_equal_range_ratio_is_H_over_the_best_basis_of_the_same_range(sweep):
    a = answer_at(sweep, "05-03", 3.0)
    assert a.cell is not None and abs(a.cell["range_N"] / 3.0 - 1) <= 0.02
    ratio = a.cell["equal_range_ratio_hysteresis"]
    assert ratio == pytest.approx(a.cell["hysteresis"] / float(basis_at_range(sweep, a.cell["range_N"])["hysteresis"]))
    assert 0 < ratio < 1


def test_dataset_follows_cf_conventions(sweep, tmp_path):
    save_dataset(sweep, tmp_path / "s.nc")
    import xarray as xr
    with xr.open_dataset(tmp_path / "s.nc", engine="h5netcdf") as ds:
        assert ds.attrs["Conventions"].startswith("CF-")
        for v in list(ds.data_vars) + list(ds.coords):
            text = ds[v].dtype.kind in "OSU"   # text (reasons, hinge-set labels): no units
            assert ({"long_name"} if text else {"units", "long_name"}) <= set(ds[v].attrs), v
            assert not (text and "units" in ds[v].attrs), v
        assert list(ds["feasible"].attrs["flag_values"]) == [0, 1]
        assert ds["feasible"].attrs["flag_meanings"] == "infeasible feasible"
    back = load_dataset(tmp_path / "s.nc")
    assert back["feasible"].dtype == bool and (back["feasible"] == sweep["feasible"]).all()


def test_best_cell_on_the_grid_edge_names_where_the_feasible_region_ends(sweep):
    """This grid stops at phi1 = 32 deg, short of the side links' limit (32.86 deg). The
    note names the phi1 where the feasible region ends at the cell's phi2 and the rule that
    ends it; checked directly: feasible 0.01 deg before, that rule broken 0.02 deg after."""
    import re

    from geometry.checks import check_design

    front = pareto_front(sweep, "03-03")
    edge = front[front["phi1_deg"] == 32.0]
    assert len(edge)                     # the front runs along the grid's last column
    a = answer_at(sweep, "03-03", float(edge["range_N"].iloc[0]))
    assert a.cell["phi1_deg"] == 32.0
    m = re.fullmatch(r"phi1 = 32 deg is the grid's last value; feasible cells go on to phi1 = "
                     r"([\d.]+) deg \((\w+)\)", a.edge)
    assert m, a.edge
    end, rule = float(m.group(1)), m.group(2)
    assert 32.0 < end <= 32.86
    phi2 = a.cell["phi2_deg"]
    assert check_design(SPEC.design("03-03", end - 0.01, phi2)).feasible
    fail = check_design(SPEC.design("03-03", end + 0.02, phi2)).first_failure
    assert fail is not None and fail.rule == rule


def test_the_answer_says_whether_its_cell_is_next_to_the_toggle(sweep):
    """An answer's ``toggle`` is its cell's own stroke change (the cell's design made here
    from its hinge set and angles, solved to the sweep's 1 mm and to its linear limit), so a
    cell of phi2 below 11 deg is marked next to the toggle, in the JSON and in the sweep's
    printed line; a cell of phi2 12 deg and above with a mild stroke is not."""
    from dataclasses import asdict

    from sensor.design_space.summary import _answer_line, _plain, _with_ratios
    from sensor.mechanics.toggle import stroke_change

    near = run_sweep(SweepSpec(phi1=Grid(26, 32, 2), phi2=Grid(8, 10, 2)), "near", workers=1)[0]
    for ds, hinges, expected in ((sweep, "05-03", False), (near, "03-03", True)):
        a = answer_at(ds, hinges, float(pareto_front(ds, hinges)["range_N"].iloc[0]))
        design = make_design(a.cell["phi1_deg"], a.cell["phi2_deg"], hinges)
        model = build_beam_model(design)
        own = stroke_change(model, solve(model, target_output_mm=1.0), design.phi2_deg).to_dict()
        assert a.toggle == pytest.approx(own, rel=1e-9) and a.toggle["near_toggle"] is expected
        assert ("[next to the toggle" in _answer_line(_with_ratios(_plain(asdict(a))))) is expected
