"""The thesis' tuning rule (sensor.pneumatic.tuning): step metrics against a second-order
response known in closed form, and the search's choice."""
import math

import numpy as np
import pytest
import xarray as xr

from sensor.pneumatic.tuning import SETTLING_BAND, step_metrics


def _second_order(zeta, wn=20.0, amplitude=24.0, step_s=1.0, end_s=4.0):
    t = np.arange(0, end_s + 5e-4, 1e-3)
    tau = np.clip(t - step_s, 0, None)
    wd = wn * math.sqrt(1 - zeta**2)
    y = amplitude * (1 - np.exp(-zeta * wn * tau) * (np.cos(wd * tau) + zeta / math.sqrt(1 - zeta**2) * np.sin(wd * tau)))
    return xr.Dataset({"environment_force": ("time", y)}, coords={"time": t})


@pytest.mark.parametrize("zeta", [0.3, 0.5, 0.7])
def test_step_metrics_of_a_second_order_response(zeta):
    # Overshoot exp(-pi zeta / sqrt(1 - zeta^2)) exactly (sampled at 1 ms: within 0.2 % of the
    # step), the damping ratio recovered from it, and the 2 % settling time: inside the band
    # from there on, outside it one sample before, and below the envelope bound
    # -ln(0.02 sqrt(1 - zeta^2)) / (zeta w_n).
    ds = _second_order(zeta)
    m = step_metrics(ds, 1.0, 24.0)
    assert m["overshoot"] == pytest.approx(math.exp(-math.pi * zeta / math.sqrt(1 - zeta**2)), abs=2e-3)
    assert m["damping_ratio"] == pytest.approx(zeta, abs=0.01)
    t, y = ds.time.values, ds.environment_force.values
    ts = m["settling_time_s"]
    after = t >= 1.0 + ts - 1e-9
    assert np.all(np.abs(y[after] - 24.0) <= SETTLING_BAND * 24.0)
    assert abs(y[np.flatnonzero(after)[0] - 1] - 24.0) > SETTLING_BAND * 24.0
    assert ts <= -math.log(0.02 * math.sqrt(1 - zeta**2)) / (zeta * 20.0)


def test_a_response_that_keeps_oscillating_never_settles():
    # a sustained 3 Hz, 5 N oscillation about the target: no settling time, its RMS reported
    t = np.arange(0, 4.0005, 1e-3)
    y = np.where(t >= 1.0, 24.0 + 5.0 * np.sin(2 * np.pi * 3 * t), 0.0)
    m = step_metrics(xr.Dataset({"environment_force": ("time", y)}, coords={"time": t}), 1.0, 24.0)
    assert m["settling_time_s"] is None
    assert m["tail_rms_N"] == pytest.approx(5.0 / math.sqrt(2), rel=0.01)
