"""How the body behaves, what the sensor reads, and the loop it serves.

A small lazy facade (``import sensor`` loads nothing heavy): the chain solver and the
qualifiers of a design, the sensor model and its datasheet, design-space sweeps, and the
errors. The subpackages hold the rest: :mod:`sensor.mechanics`, :mod:`sensor.readout`,
:mod:`sensor.design_space`, :mod:`sensor.pneumatic`; :mod:`sensor.cli` is the ``dacm``
command.

>>> import geometry, sensor
>>> model = geometry.build_beam_model(geometry.preset("sample-b"))
>>> q = sensor.qualify(sensor.solve(model, target_output_mm=1.0))
>>> round(q.amplification, 1) > 1
True
"""

from __future__ import annotations

import importlib

_EXPORTS = {
    "solve": "sensor.mechanics.solver",
    "solve_batch": "sensor.mechanics.solver",
    "SolveResult": "sensor.mechanics.solver",
    "SolverOptions": "sensor.mechanics.solver",
    "Qualifiers": "sensor.mechanics.qualifiers",
    "qualify": "sensor.mechanics.qualifiers",
    "StrainEnergyLaw": "sensor.mechanics.hysteresis",
    "DEFAULT_LAW": "sensor.mechanics.hysteresis",
    "hysteresis": "sensor.mechanics.hysteresis",
    "build_sensor": "sensor.readout.sensor_model",
    "Readout": "sensor.readout.sensor_model",
    "OpticsSetup": "sensor.readout.optics",
    "datasheet": "sensor.readout.datasheet",
    "SweepSpec": "sensor.design_space.spec",
    "Grid": "sensor.design_space.spec",
    "run_sweep": "sensor.design_space.execution",
    "load_dataset": "sensor.design_space.dataset",
    "SensorError": "sensor.errors",
    "SensorInputError": "sensor.errors",
    "SolverError": "sensor.errors",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    if name in _EXPORTS:
        value = getattr(importlib.import_module(_EXPORTS[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'sensor' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))
