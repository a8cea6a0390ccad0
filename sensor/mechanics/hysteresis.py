"""Hysteresis of a loading-unloading loop (eq 87), the strain-energy law and sensor quality.

Thesis section 6.2.5 and Table 6: hysteresis H = max(delta f) / F_max, where delta f is the
largest gap between the outputs at the same input on the loading and unloading branches and
F_max the output range. The thesis' hypothesis, supported by Table 6, is that H grows in
proportion to the strain energy SE needed for the output travel (H / SE = 0.062, 0.056 and
0.065 per mJ for the basis, sample A and sample B). Quality = sensitivity / H.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sensor.errors import HysteresisError, SensorInputError
from sensor.validation import is_real, require


@dataclass(frozen=True)
class Specimen:
    """One row of thesis Table 6: measured values, and the thesis' analytic ones."""

    name: str
    strain_energy_mJ: float
    strain_energy_model_mJ: float
    hysteresis: float
    sensitivity_mm_per_N: float
    sensitivity_model_mm_per_N: float
    quality: float


#: Thesis Table 6 (analytic values are the numbers in parentheses).
TABLE6 = {
    "basis": Specimen("basis", 2.187, 2.385, 0.135, 0.227, 0.202, 1.682),
    "sample-a": Specimen("sample-a", 0.815, 0.941, 0.046, 0.281, 0.239, 6.109),
    "sample-b": Specimen("sample-b", 0.550, 0.684, 0.036, 0.204, 0.178, 5.667),
}


def hysteresis(inputs, outputs) -> float:
    """H = max(delta f) / F_max (eq 87) of one loading-unloading loop.

    ``inputs`` is what was imposed (e.g. displacement), ``outputs`` what was read (e.g.
    force), in time order: the loop loads up to the largest input and unloads after it.
    Both branches are interpolated onto the inputs they share; F_max is the output range.
    """
    x = np.asarray(inputs, dtype=float)
    f = np.asarray(outputs, dtype=float)
    if x.shape != f.shape or x.ndim != 1:
        raise HysteresisError(f"inputs and outputs must be 1-D of one length, got {x.shape} and {f.shape}")
    if len(x) < 4 or not np.isfinite(x).all() or not np.isfinite(f).all():
        raise HysteresisError(f"a loop needs at least 4 finite samples, got {len(x)}")
    turn = int(np.argmax(x))
    if turn == 0 or turn == len(x) - 1:
        raise HysteresisError("the loop has no unloading branch: the largest input is at an end")
    load_x, load_f = x[: turn + 1], f[: turn + 1]
    unload_x, unload_f = x[turn:][::-1], f[turn:][::-1]
    lo = max(load_x.min(), unload_x.min())
    hi = x[turn]
    grid = np.linspace(lo, hi, 512)
    gap = np.abs(_branch(load_x, load_f, grid) - _branch(unload_x, unload_f, grid))
    span = f.max() - f.min()
    if span <= 0:
        raise HysteresisError("the output range F_max is zero")
    return float(gap.max() / span)


def _branch(x, f, grid):
    """Interpolate one branch (sorted by input; repeated inputs averaged)."""
    order = np.argsort(x, kind="stable")
    xs, fs = x[order], f[order]
    ux, inv = np.unique(xs, return_inverse=True)
    uf = np.bincount(inv, weights=fs) / np.bincount(inv)
    return np.interp(grid, ux, uf)


def hysteresis_from_csv(path: str | Path, input_column: str = "displacement_mm",
                        output_column: str = "force_N") -> float:
    """H (eq 87) of a measured loop in a CSV file with a header row naming the columns."""
    with open(path, newline="") as fh:
        reader = csv.DictReader(fh)
        cols = reader.fieldnames or []
        for c in (input_column, output_column):
            if c not in cols:
                raise HysteresisError(f"{path}: no column {c!r}; columns are {', '.join(cols)}")
        try:
            rows = [(float(r[input_column]), float(r[output_column])) for r in reader]
        except ValueError as exc:
            raise HysteresisError(f"{path}: non-numeric value: {exc}") from None
    if not rows:
        raise HysteresisError(f"{path}: no data rows")
    x, f = np.array(rows).T
    return hysteresis(x, f)


#: The largest hysteresis the strain-energy law is used for (fraction of full scale): the law
#: is linear in SE, fitted on Table 6's specimens (H 0.036-0.135); past half the range a loop
#: is no longer a small offset about the calibration curve, and the sensor model (its gap
#: table, its calibration) refuses such a body.
H_LIMIT = 0.5


@dataclass(frozen=True)
class StrainEnergyLaw:
    """H = h_per_mJ * SE (thesis section 6.2.5 hypothesis), calibrated on one specimen."""

    h_per_mJ: float
    calibrated_on: str

    def __post_init__(self):
        require(is_real(self.h_per_mJ) and 0 <= self.h_per_mJ <= 1e3, "h_per_mJ", self.h_per_mJ,
                "a number in [0, 1000] (per mJ; Table 6 gives about 0.06, 0 is a body "
                "without hysteresis)")
        require(isinstance(self.calibrated_on, str), "calibrated_on", self.calibrated_on,
                "the name of the specimen the law was calibrated on")

    @property
    def max_strain_energy_mJ(self) -> float:
        """The strain energy (mJ) at which the law predicts :data:`H_LIMIT` (inf without
        hysteresis)."""
        return H_LIMIT / self.h_per_mJ if self.h_per_mJ > 0 else math.inf

    def predict(self, strain_energy_mJ):
        """Predicted hysteresis (fraction of full scale) for a strain energy in mJ, in
        [0, 1e6] (NaN, the mark of a failed solve, gives NaN)."""
        try:
            se = np.asarray(strain_energy_mJ, dtype=float)
        except (TypeError, ValueError):
            se = None
        require(se is not None, "strain_energy_mJ", strain_energy_mJ, "a number or an array of numbers (mJ)")
        bad = se[~(np.isnan(se) | ((se >= 0) & (se <= 1e6)))]  # negative, huge or infinite
        require(bad.size == 0, "strain_energy_mJ", float(bad[0]) if bad.size else None,
                "a number in [0, 1e6] (mJ)")
        return self.h_per_mJ * se

    @classmethod
    def calibrate(cls, specimen: str = "basis") -> "StrainEnergyLaw":
        """Calibrate on one specimen of Table 6 (its measured H and measured SE)."""
        if specimen not in TABLE6:
            raise SensorInputError(f"specimen = {specimen!r}: must be one of {', '.join(TABLE6)}")
        s = TABLE6[specimen]
        return cls(s.hysteresis / s.strain_energy_mJ, specimen)

    def errors_on_table6(self) -> dict[str, float]:
        """Relative error of the predicted H on each Table 6 specimen (from measured SE)."""
        return {k: float(self.predict(s.strain_energy_mJ) / s.hysteresis - 1.0) for k, s in TABLE6.items()}


#: The law used by default: calibrated on the basis specimen.
DEFAULT_LAW = StrainEnergyLaw.calibrate("basis")


def quality(sensitivity_mm_per_N, hysteresis_fraction):
    """Overall quality ("SNR" of Table 6) = sensitivity / hysteresis, mm/N (infinite for a
    body without hysteresis)."""
    with np.errstate(divide="ignore"):
        return np.asarray(sensitivity_mm_per_N, dtype=float) / np.asarray(hysteresis_fraction, dtype=float)


# --- rate-independent loops: Preisach model with a uniform weight ----------------------------

#: Memory of a virgin (never loaded) body: turning points (0,) and the current input 0.
VIRGIN = (0.0, 0.0)


def preisach_update(state: tuple[float, ...], s: float) -> tuple[float, ...]:
    """New memory after the normalised input moves to ``s`` (0..1).

    ``state`` = (p_0 = 0, p_1, ..., p_k, u): alternating turning points (minima at even
    index, maxima at odd) and the current input u. A reversal pushes u; passing the older
    extremum of the last pair wipes that pair out (Preisach wiping-out property).
    """
    *pts, u = state
    if s == u:
        return state
    rising = s > u
    if rising != (len(pts) % 2 == 1):           # the last segment ran the other way
        pts.append(u)
    while len(pts) >= 3 and (s >= pts[-2] if rising else s <= pts[-2]):
        del pts[-2:]
    if len(pts) == 2 and s <= pts[0]:           # back down to the unloaded state
        del pts[1:]
    return (*pts, s)


def preisach_offset(state: tuple[float, ...], mu: float) -> float:
    """h = P - mu (u - 1/2), fraction of full-scale travel, of a memory state."""
    total = -0.5 * mu
    for j in range(1, len(state)):
        d = state[j] - state[j - 1]
        total += mu * d * d if j % 2 == 1 else -mu * d * d
    return total - mu * (state[-1] - 0.5)


def preisach_offsets(inputs, mu: float, state: tuple[float, ...] = VIRGIN):
    """Offsets h (fraction of full scale) along a normalised input history (0..1) from a
    memory ``state``; returns (h, final state). A full loop 0 -> 1 -> 0 has hysteresis
    mu / 2 by eq 87, so ``mu = 2 H`` gives a loop of hysteresis H."""
    s = np.asarray(inputs, dtype=float)
    h = np.empty_like(s)
    for i, si in enumerate(s):
        state = preisach_update(state, float(si))
        h[i] = preisach_offset(state, mu)
    return h, state
