"""Errors raised by :mod:`sensor` (solver, sensor model, sweeps, pneumatics)."""


class SensorError(ValueError):
    """Base class: input the sensor tools cannot accept, or a computation that failed."""
