"""Sensor models read by the fixed-rate controller loop.

Every sensor is an object with ``read(value, t) -> float`` (SI units); any object with that
method can replace a default, e.g. the DACM optical force-sensor model for ``force``.
Noise is Gaussian with the given standard deviation, drawn from the sensor's own seeded
generator; quantisation rounds to the resolution (an encoder truncates to whole counts).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from sensor.errors import SensorInputError


def _nonneg(owner: str, name: str, value: float) -> None:
    if not (math.isfinite(value) and value >= 0):
        raise SensorInputError(f"{owner} {name} = {value!r}: must be a finite number >= 0")


class NoisyQuantised:
    """value + N(0, noise) rounded to ``resolution`` (0: no rounding)."""

    def __init__(self, noise: float = 0.0, resolution: float = 0.0, seed: int | None = 0,
                 name: str = "sensor") -> None:
        _nonneg(name, "noise", noise)
        _nonneg(name, "resolution", resolution)
        self.noise, self.resolution, self.name = float(noise), float(resolution), name
        self._rng = np.random.default_rng(seed)
        self._buffer: list[float] = []
        self._next = 0

    def _refill(self) -> None:
        """A fresh block of the stream when the current one is used up."""
        if self._next >= len(self._buffer):
            self._buffer = self._rng.standard_normal(4096).tolist()
            self._next = 0

    def _draw(self) -> float:
        self._refill()
        self._next += 1
        return self._buffer[self._next - 1]

    def _advance(self, n: int, out: np.ndarray | None = None) -> None:
        """Move the stream n draws on, copying them into ``out`` if given."""
        i = 0
        while i < n:
            self._refill()
            take = min(n - i, len(self._buffer) - self._next)
            if out is not None:
                out[i:i + take] = self._buffer[self._next:self._next + take]
            self._next += take
            i += take

    def upcoming(self, n: int) -> np.ndarray:
        """The standard-normal draws of the next n noisy reads, without consuming them: the same
        stream :meth:`read` would use (the compiled loop reads in bulk, then :meth:`consume`)."""
        saved = self._rng.bit_generator.state, self._buffer, self._next
        out = np.empty(n)
        self._advance(n, out)
        self._rng.bit_generator.state, self._buffer, self._next = saved
        return out

    def consume(self, n: int) -> None:
        """Advance the noise stream by n draws, as n noisy reads would."""
        self._advance(n)

    def read(self, value: float, t: float) -> float:
        y = value + self.noise * self._draw() if self.noise > 0 else value
        if self.resolution > 0:
            y = math.floor(y / self.resolution + 0.5) * self.resolution
        return y


def potentiometer(range_m: float = 0.05, bits: int = 16, noise_m: float = 5e-6, seed: int = 1) -> NoisyQuantised:
    """Linear potentiometer through an ADC: range / 2^bits resolution, white noise."""
    return NoisyQuantised(noise_m, range_m / 2**bits, seed, "potentiometer")


class Encoder:
    """Incremental encoder: position truncated to whole counts of ``count_m``."""

    def __init__(self, count_m: float = 1e-6) -> None:
        if not (math.isfinite(count_m) and count_m > 0):
            raise SensorInputError(f"encoder count_m = {count_m!r}: must be a positive finite number")
        self.count_m = float(count_m)

    def read(self, value: float, t: float) -> float:
        return math.floor(value / self.count_m) * self.count_m


def load_cell(noise_N: float = 0.02, resolution_N: float = 0.005, seed: int = 2) -> NoisyQuantised:
    """Default force sensor: a load cell with white noise and ADC quantisation."""
    return NoisyQuantised(noise_N, resolution_N, seed, "force sensor")


def pressure_transducer(noise_Pa: float = 200.0, resolution_Pa: float = 50.0, seed: int = 3) -> NoisyQuantised:
    """Pressure sensor (absolute Pa) with white noise and quantisation (P51-class)."""
    return NoisyQuantised(noise_Pa, resolution_Pa, seed, "pressure sensor")


class DifferentiatingFilter:
    """First-order filtered derivative y = s / (1 + s / w_c) x, discretised with the bilinear
    (Tustin) rule at the loop rate; the thesis uses w_c = 2 pi 50 Hz for velocity and
    acceleration (sections 4.4 and 5.4)."""

    def __init__(self, cutoff_Hz: float, dt_s: float) -> None:
        if not (math.isfinite(cutoff_Hz) and cutoff_Hz > 0):
            raise SensorInputError(f"differentiation cutoff_Hz = {cutoff_Hz!r}: must be a positive finite number")
        wc = 2 * math.pi * cutoff_Hz
        self._a = (2 - wc * dt_s) / (2 + wc * dt_s)
        self._b = 2 * wc / (2 + wc * dt_s)
        self._x = None
        self._y = 0.0

    @property
    def coefficients(self) -> tuple[float, float]:
        """(a, b) of the recursion y_k = a y_(k-1) + b (x_k - x_(k-1)), for compiled copies."""
        return self._a, self._b

    def update(self, x: float) -> float:
        if self._x is None:
            self._x = x
        self._y = self._a * self._y + self._b * (x - self._x)
        self._x = x
        return self._y


@dataclass
class Sensors:
    """The rig's sensors: position, force, and pressure at valve ports and chamber inlets."""

    position: object = field(default_factory=potentiometer)
    force: object = field(default_factory=load_cell)
    pressure_valve_1: object = field(default_factory=lambda: pressure_transducer(seed=3))
    pressure_valve_2: object = field(default_factory=lambda: pressure_transducer(seed=4))
    pressure_chamber_1: object = field(default_factory=lambda: pressure_transducer(seed=5))
    pressure_chamber_2: object = field(default_factory=lambda: pressure_transducer(seed=6))
    differentiation_cutoff_Hz: float = 50.0

    def __post_init__(self) -> None:
        for name in ("position", "force", "pressure_valve_1", "pressure_valve_2",
                     "pressure_chamber_1", "pressure_chamber_2"):
            if not callable(getattr(getattr(self, name), "read", None)):
                raise SensorInputError(f"sensor {name}: must have a read(value, t) method")


def ideal_sensors() -> Sensors:
    """Noise-free, unquantised sensors (for tests and model comparisons)."""
    perfect = lambda: NoisyQuantised(0.0, 0.0, None)  # noqa: E731
    return Sensors(perfect(), perfect(), perfect(), perfect(), perfect(), perfect())
