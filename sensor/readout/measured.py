"""Measured loading-unloading loops: eq 87 hysteresis, sensitivity and nonlinearity, set
beside the model of the same design, and the fit of E and of the strain-energy law.

A loop is a force history (N, in time order: loading to the largest force, then unloading)
and what was read at each force: the mirror (output) travel in mm, or the sensor's volts.
Its figures, the same way the datasheet states a simulated loop (thesis section 6.2.5):

- hysteresis (eq 87): max |y_unload - y_load| at equal force / span of y;
- sensitivity: slope of the least-squares line y = a + b F over both branches (mm/N or V/N);
- nonlinearity: largest distance of the mean branch from that line / span of y.

The beam model's forces are proportional to E at a given shape (every member's stiffness
is, with nu fixed), so a force-displacement loop gives E by least squares of the measured
mean branch against the model's curve at the same travels, in one solve.
"""

from __future__ import annotations

import csv
import math
import re
import stat
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.interpolate import PchipInterpolator

from geometry.params import Design
from geometry.topology import build_beam_model
from sensor.errors import HysteresisError
from sensor.mechanics.hysteresis import StrainEnergyLaw, hysteresis, preisach_offsets
from sensor.mechanics.solver import SolverOptions, solve
from sensor.readout.sensor_model import build_sensor, loading_cycle

#: What the second column of a loop holds.
KINDS = {"displacement": "mm", "volts": "V"}
#: The unit of each column.
UNITS = {"force": "N", **KINDS}
#: The CSV a loop is read from, as the one-line errors state it.
CSV_SCHEMA = {k: f"force_N,{k}_{u} (force in N, then {k} in {u}; the header row is optional)"
              for k, u in KINDS.items()}
#: The largest file and row count read (the size is checked before reading).
MAX_BYTES = 256 << 20
MAX_ROWS = 10_000_000
#: The largest magnitude of each column: a force beyond 10 kN, a travel beyond 1 m or a
#: reading beyond 1 kV is not a measurement of a sensor with a range of a few N and a 25 mm
#: body (the model could not be solved to it either).
VALUE_LIMITS = {"force": (1e4, "N"), "displacement": (1e3, "mm"), "volts": (1e3, "V")}


@dataclass(frozen=True, eq=False)
class Loop:
    """One measured loop: force (N) and the response (``kind``: displacement mm or volts)."""

    force_N: np.ndarray
    response: np.ndarray
    kind: str
    source: str = "loop"

    def __post_init__(self):
        f = np.asarray(self.force_N, dtype=float)
        y = np.asarray(self.response, dtype=float)
        if self.kind not in KINDS:
            raise HysteresisError(f"kind = {self.kind!r}: must be one of {', '.join(KINDS)}")
        if f.shape != y.shape or f.ndim != 1:
            raise HysteresisError(f"{self.source}: force and response must be 1-D of one length, "
                                  f"got {f.shape} and {y.shape}")
        if len(f) < 8:
            raise HysteresisError(f"{self.source}: {len(f)} rows: a loop needs at least 8")
        bad = np.flatnonzero(~(np.isfinite(f) & np.isfinite(y)))
        if len(bad):
            raise HysteresisError(f"{self.source}: row {bad[0] + 1} is not finite")
        turn = int(np.argmax(f))
        if turn in (0, len(f) - 1):
            raise HysteresisError(f"{self.source}: the largest force is at an end: "
                                  "must load up, then unload")
        if not f.max() > 0:
            raise HysteresisError(f"{self.source}: the largest force {f.max():g} N must be > 0")
        object.__setattr__(self, "force_N", f)
        object.__setattr__(self, "response", y)

    @property
    def turn(self) -> int:
        return int(np.argmax(self.force_N))


@dataclass(frozen=True)
class LoopFigures:
    """What a loop states (units: response unit per N for sensitivity)."""

    kind: str
    max_force_N: float
    span: float                  # response span (mm or V)
    hysteresis: float            # eq 87, fraction of the span
    sensitivity: float           # least-squares slope, mm/N or V/N
    nonlinearity_pct: float      # % of the span
    unit: str


def read_loop_csv(path: str | Path, kind: str = "displacement") -> Loop:
    """A loop from a CSV file, by its declared schema (:data:`CSV_SCHEMA`): exactly two
    columns, force (N) then the response (mm or V), in every row; a header row is optional
    and, when present, names the columns ``force...`` and ``KIND...`` (in either order), with
    their units if it gives any (``force_N``, ``displacement [mm]``, ``volts_V``); every value
    a finite number within :data:`VALUE_LIMITS`. The file must be a regular file of at most
    :data:`MAX_BYTES` (checked before reading) and :data:`MAX_ROWS` rows. Anything else is
    one :class:`HysteresisError` naming the file, the row and the rule."""
    path = Path(path)
    if kind not in KINDS:
        raise HysteresisError(f"--columns force,{kind}: must be force,displacement or force,volts")
    info = path.stat()  # FileNotFoundError etc. name the path
    if not stat.S_ISREG(info.st_mode):
        raise HysteresisError(f"{path}: not a regular file (a CSV file is read, not a device, "
                              "folder or pipe)")
    if info.st_size > MAX_BYTES:
        raise HysteresisError(f"{path}: {info.st_size} bytes: at most {MAX_BYTES} are read "
                              f"({MAX_ROWS} rows of two numbers)")
    try:
        with path.open(newline="", encoding="utf-8") as fh:
            rows = [r for r in csv.reader(fh) if any(c.strip() for c in r)]
    except UnicodeDecodeError:
        raise HysteresisError(f"{path}: not a text CSV file (bytes that are not UTF-8)") from None
    except csv.Error as exc:
        raise HysteresisError(f"{path}: not a CSV loop ({exc})") from None
    if not rows:
        raise HysteresisError(f"{path}: no data rows")
    if len(rows) > MAX_ROWS:
        raise HysteresisError(f"{path}: {len(rows)} rows: at most {MAX_ROWS} are read")
    cols, first = (0, 1), 1
    if _numeric(rows[0]):
        first = 0
    else:
        header = [c.strip().lower() for c in rows[0]]
        if len(header) != 2:
            raise HysteresisError(f"{path}: the header has {len(header)} columns "
                                  f"({', '.join(header)}); a loop has exactly two: {CSV_SCHEMA[kind]}")
        cols = (_column(header, "force", path, kind), _column(header, kind, path, kind))
    data = np.empty((len(rows) - first, 2))
    for n, row in enumerate(rows[first:]):
        if len(row) != 2:
            raise HysteresisError(f"{path}: row {n + first + 1} has {len(row)} columns; a loop "
                                  f"has exactly two: {CSV_SCHEMA[kind]}")
        try:
            data[n] = float(row[cols[0]]), float(row[cols[1]])
        except ValueError:
            raise HysteresisError(f"{path}: row {n + first + 1}: every data row needs two numbers "
                                  f"({CSV_SCHEMA[kind]})") from None
    if not len(data):
        raise HysteresisError(f"{path}: no data rows")
    for j, name in enumerate(("force", kind)):
        limit, unit = VALUE_LIMITS[name]
        big = np.flatnonzero(np.isfinite(data[:, j]) & (np.abs(data[:, j]) > limit))
        if len(big):
            raise HysteresisError(f"{path}: row {big[0] + first + 1}: {name} {data[big[0], j]:g} {unit} "
                                  f"is beyond +-{limit:g} {unit}, not a measurement of this sensor")
    return Loop(data[:, 0], data[:, 1], kind, str(path))


def _numeric(row) -> bool:
    try:
        [float(c) for c in row[:2]]
    except ValueError:
        return False
    return len(row) >= 2


def _column(header: list[str], prefix: str, path: Path, kind: str) -> int:
    hits = [i for i, c in enumerate(header) if c.startswith(prefix)]
    if len(hits) != 1:
        raise HysteresisError(f"{path}: needs one column named {prefix}...; the header is "
                              f"{', '.join(header)} ({CSV_SCHEMA[kind]})")
    name = header[hits[0]]
    unit = UNITS["force" if prefix == "force" else kind]
    given = re.fullmatch(rf"{prefix}\s*(?:_|\[|\()?\s*([a-z]*)\s*[\])]?", name)
    if given is None or given.group(1) not in ("", unit.lower()):
        raise HysteresisError(f"{path}: column {name!r}: must be {prefix} in {unit} "
                              f"({CSV_SCHEMA[kind]})")
    return hits[0]


def _mean_branch(loop: Loop, grid: np.ndarray) -> np.ndarray:
    """The mean of the loading and unloading branches at the forces of ``grid``."""
    f, y, k = loop.force_N, loop.response, loop.turn

    def branch(ff, yy):
        order = np.argsort(ff, kind="stable")
        return np.interp(grid, ff[order], yy[order])

    return 0.5 * (branch(f[: k + 1], y[: k + 1]) + branch(f[k:], y[k:]))


def loop_figures(loop: Loop) -> LoopFigures:
    """Hysteresis (eq 87), sensitivity and nonlinearity of a loop (see the module text)."""
    f, y = loop.force_N, loop.response
    span = float(np.ptp(y))
    if not span > 0:
        raise HysteresisError(f"{loop.source}: the response does not change over the loop")
    a, b = np.polynomial.polynomial.polyfit(f, y, 1)
    lo = max(f[: loop.turn + 1].min(), f[loop.turn:].min())
    grid = np.linspace(lo, f.max(), 256)
    nonlin = np.max(np.abs(_mean_branch(loop, grid) - (a + b * grid))) / span
    return LoopFigures(loop.kind, float(f.max()), span, hysteresis(f, y), float(b),
                       100.0 * float(nonlin), KINDS[loop.kind])


@dataclass(frozen=True)
class ModulusFit:
    """E that makes the beam model's force-travel curve match a measured loop."""

    E_MPa: float
    E_model_MPa: float
    rms_residual_N: float        # of the measured mean branch against the fitted model
    strain_energy_mJ: float      # the fitted model's, at the loop's largest travel


def fit_modulus(loop: Loop, design: Design) -> ModulusFit:
    """Least-squares E from a force-displacement loop (displacement = mirror travel, mm).

    The model is solved once, at the design's E, to the loop's largest mean-branch travel;
    its forces scale with E at every shape, so F_meas(x) = (E / E_model) F_model(x).
    """
    if loop.kind != "displacement":
        raise HysteresisError("E is fitted from a force,displacement loop (volts depend on "
                              "the optics as well)")
    f, k = loop.force_N, loop.turn
    lo = max(f[: k + 1].min(), f[k:].min())
    grid = np.linspace(lo, f.max(), 64)[1:]
    travel = _mean_branch(loop, grid)
    if np.any(np.diff(travel) <= 0):
        raise HysteresisError(f"{loop.source}: the mean travel does not grow with the force: "
                              "not a loop of this body")
    r = solve(build_beam_model(design), target_output_mm=float(travel[-1]),
              options=SolverOptions(increments=16))
    f_model = np.interp(travel, r.output_mm, r.force_N)
    scale = float(np.dot(grid, f_model) / np.dot(f_model, f_model))
    resid = float(np.sqrt(np.mean((grid - scale * f_model) ** 2)))
    return ModulusFit(design.material.E_MPa * scale, design.material.E_MPa, resid,
                      r.strain_energy_mJ * scale)


def fit_law(loop: Loop, strain_energy_mJ: float) -> StrainEnergyLaw:
    """The strain-energy law H = c SE through this loop's hysteresis and the model's SE (mJ)
    at the loop's full scale (thesis section 6.2.5: one specimen calibrates the law)."""
    if not (math.isfinite(strain_energy_mJ) and strain_energy_mJ > 0):
        raise HysteresisError(f"strain_energy_mJ = {strain_energy_mJ!r}: must be > 0")
    return StrainEnergyLaw(loop_figures(loop).hysteresis / strain_energy_mJ, loop.source)


def model_loop(design: Design, kind: str, max_force_N: float, law: StrainEnergyLaw,
               points: int = 201) -> Loop:
    """The model's loop 0 -> max_force_N -> 0 for a design: the solved force-travel curve with
    the law's hysteresis (the sensor model's Preisach loop); for volts, read through the
    sensor model (default optics and ADC, noise-free)."""
    if not (math.isfinite(max_force_N) and max_force_N > 0):
        raise HysteresisError(f"max_force_N = {max_force_N!r}: must be > 0")
    forces = loading_cycle(max_force_N, points)
    if kind == "volts":
        sensor = build_sensor(design, law=law)
        if max_force_N > sensor.range_N:
            raise HysteresisError(f"the loop reaches {max_force_N:.4g} N, beyond the model sensor's "
                                  f"range {sensor.range_N:.4g} N (1 mm of mirror travel)")
        return Loop(forces, sensor.read(forces).volts, kind, "model")
    r = solve(build_beam_model(design), target_force_N=max_force_N,
              options=SolverOptions(increments=16))
    h, _ = preisach_offsets(forces / max_force_N, 2.0 * float(law.predict(r.strain_energy_mJ)))
    travel = PchipInterpolator(r.force_N, r.output_mm)(forces) + r.output_travel_mm * h
    return Loop(forces, travel, kind, "model")
