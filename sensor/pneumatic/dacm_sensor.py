"""The bridge from a DACM sensor model (:mod:`sensor.readout`) to the pneumatic loop: a force
sensor the loop reads each sample, the series spring its body makes with the environment, and
the reference that keeps a run inside its range."""
from __future__ import annotations

import numpy as np

from sensor.errors import SensorInputError


class DacmForceSensor:
    """A DACM sensor model as the loop's force sensor: ``read(value, t)`` returns the calibrated
    newtons of one sample (hysteresis memory, optical noise, ADC); forces outside [0, range] are
    clipped and flagged by the model (``overload="saturate"``).  ``stiffness_N_m``: the secant
    stiffness range / input travel at full scale, put in series with the environment."""

    def __init__(self, source: str, seed: int = 0):
        from pathlib import Path

        from geometry.params import PRESETS, load_design, preset
        from sensor.readout.datasheet import datasheet
        from sensor.readout.sensor_model import build_sensor

        if source in PRESETS:
            design = preset(source)
        elif source.endswith(".toml"):
            design = load_design(Path(source))
        else:
            raise SensorInputError(f"sensor = {source!r}: must be a preset ({', '.join(PRESETS)}) or a .toml design file")
        self.model = build_sensor(design, overload="saturate")
        self.sheet = datasheet(self.model)
        self.name = self.model.name
        self.range_N = float(self.model.range_N)
        self.stiffness_N_m = self.range_N / self.model.input_travel_mm * 1e3
        self._stepper = self.model.stepper(np.random.default_rng(seed))

    def read(self, value: float, t: float) -> float:
        return self._stepper.step(value).newtons


def series_spring(environment_N_m: float, sensor_N_m: float) -> float:
    """Stiffness (N/m) of the environment spring and the sensor body in series."""
    return 1.0 / (1.0 / environment_N_m + 1.0 / sensor_N_m)


def sensor_reference(range_N: float) -> tuple[float, float]:
    """(amplitude, offset) in N of a sine between 15 % and 85 % of a sensor's range."""
    return 0.35 * range_N, 0.5 * range_N
