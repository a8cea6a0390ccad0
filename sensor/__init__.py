"""How the body behaves, what the sensor reads, and the loop it serves.

A small lazy facade (``import sensor`` loads nothing heavy): the chain solver and the
qualifiers of a design, the sensor model and its datasheet, design-space sweeps, the
range-targeted optimiser, and the errors. The subpackages hold the rest: :mod:`sensor.mechanics`, :mod:`sensor.readout`,
:mod:`sensor.design_space`, :mod:`sensor.pneumatic`, :mod:`sensor.artefact` (the MRI
artefact); :mod:`sensor.cli` is the ``dacm``
command.

>>> import geometry, sensor
>>> model = geometry.build_beam_model(geometry.preset("sample-b"))
>>> q = sensor.qualify(sensor.solve(model, target_output_mm=1.0))
>>> round(q.amplification, 1) > 1
True
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "mechanics.solver": ["SolveResult", "SolverOptions", "solve", "solve_batch"],
        "mechanics.qualifiers": ["Qualifiers", "qualify"],
        "mechanics.hysteresis": ["DEFAULT_LAW", "StrainEnergyLaw", "hysteresis"],
        "mechanics.toggle": ["StrokeChange", "stroke_change"],
        "readout.sensor_model": ["Readout", "build_sensor"],
        "readout.optics": ["OpticsSetup"],
        "readout.datasheet": ["datasheet"],
        "design_space.spec": ["Grid", "SweepSpec"],
        "design_space.execution": ["run_sweep"],
        "design_space.dataset": ["load_dataset"],
        "design_space.optimise": ["DesignProblem", "optimise"],
        "errors": ["DesignError", "SensorError", "SensorInputError", "SolverError"],
    },
)
