"""The sensor figures state the datasheet's numbers: one nonlinearity per sensor (the
datasheet's, force to volts), printed as the datasheet prints it."""

import pytest

from geometry.params import preset
from sensor.readout.datasheet import datasheet
from sensor.readout.plots import calibration_figure, intensity_figure
from sensor.readout.sensor_model import build_sensor


@pytest.fixture(scope="module")
def sample_a():
    sensor = build_sensor(preset("sample-a-as-cut"))
    return sensor, datasheet(sensor)


def _texts(fig) -> list[str]:
    ax = fig.axes[0]
    return [t.get_text() for t in ax.get_legend().get_texts()] + [t.get_text() for t in ax.texts]


def test_both_figures_state_the_datasheet_nonlinearity(sample_a):
    sensor, ds = sample_a
    stated = f"{ds.nonlinearity_pct:.2f} % FS"
    for fig in (intensity_figure(sensor, ds, 1.0), calibration_figure(sensor, ds)):
        texts = _texts(fig)
        assert sum(stated in t for t in texts) == 1, texts
        # no other percentage called nonlinearity
        assert all(stated in t for t in texts if "nonlinear" in t), texts
