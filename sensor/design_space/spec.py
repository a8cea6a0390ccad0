"""What a phi1 x phi2 sweep computes: the grids, the hinge sets, the target travel, the
Monte-Carlo settings and the hysteresis law (thesis section 6.2.3, Figure 49)."""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field

import numpy as np

from geometry.errors import GeometryError
from geometry.params import HINGE_SETS, Design, design_from_dict, hinge_set_thicknesses
from sensor.errors import SweepError
from sensor.mechanics.hysteresis import DEFAULT_LAW, StrainEnergyLaw
from sensor.validation import Number, is_integer

#: Bounds on a sweep's size, checked before anything is allocated: points per grid axis,
#: cells of the whole sweep, and solves including Monte-Carlo draws (about a day on 2 cores).
#: The client grows by about 1.3 kB a cell (1.5 GB at 10^6 cells; README, Performance);
#: the workers' memory does not grow with the grid.
MAX_GRID_N = 2000
MAX_CELLS = 1_000_000
MAX_SOLVES = 10_000_000
_ANGLE = Number(0.0, 90.0, lo_open=True, hi_open=True, unit="deg")
_GRID_N = Number(1, MAX_GRID_N, integer=True)
#: The basis family (DESIGN section 13): hinges 1-8 of the basis body from the process'
#: ``min_feature_mm`` up to FAMILY_SPAN times that, at FAMILY_POINTS geometric steps (range
#: grows about as t^3, so each step is about 1.35 x in range; log-log interpolation between
#: steps is within 0.5 % of a solve, tests/design_space/test_equal_range.py).
FAMILY_POINTS = 16
FAMILY_SPAN = 5.0
#: Rules of the numeric fields of :class:`SweepSpec` (named as in the sweep TOML).
SPEC_RULES = {"monte_carlo": Number(0, 100_000, integer=True),
              "hinge_sd_mm": Number(0.0, 1.0, unit="mm"),
              "seed": Number(0, 2**63 - 1, integer=True)}


@dataclass(frozen=True)
class Grid:
    """An inclusive grid START:STOP:N of angles in degrees."""

    start: float
    stop: float
    n: int

    def __post_init__(self):
        self.check(self.start, self.stop, self.n, "Grid")
        for name, kind in (("start", float), ("stop", float), ("n", int)):  # plain numbers
            object.__setattr__(self, name, kind(getattr(self, name)))

    @classmethod
    def parse(cls, text: str, name: str) -> "Grid":
        parts = str(text).split(":")
        try:
            start, stop, n = float(parts[0]), float(parts[1]), int(parts[2])
        except (IndexError, ValueError):
            raise SweepError(f"{name} = {text!r}: must be START:STOP:N (degrees, degrees, count)") from None
        if len(parts) != 3:
            raise SweepError(f"{name} = {text!r}: must be START:STOP:N (degrees, degrees, count)")
        cls.check(start, stop, n, name)
        return cls(start, stop, n)

    @staticmethod
    def check(start, stop, n, name: str) -> None:
        """Raise :class:`SweepError` naming ``name`` unless START:STOP:N is a grid of angles."""
        text = f"{start!r}:{stop!r}:{n!r}"
        if is_integer(n) and n < 1:
            raise SweepError(f"{name} = {text}: the grid is empty (N = {n}; need N >= 1)")
        for field_, rule, value in (("START", _ANGLE, start), ("STOP", _ANGLE, stop), ("N", _GRID_N, n)):
            if not rule.ok(value):
                raise SweepError(f"{name} = {text}: {field_} = {value!r}: must be {rule.rule}")
        if stop < start or (n > 1 and stop == start):
            raise SweepError(f"{name} = {text}: STOP must exceed START (or equal it for N = 1)")

    def validated(self, name: str) -> "Grid":
        self.check(self.start, self.stop, self.n, name)
        return self

    @property
    def values(self) -> np.ndarray:
        return np.linspace(self.start, self.stop, self.n)

    def __str__(self):
        return f"{self.start:g}:{self.stop:g}:{self.n}"


@dataclass(frozen=True)
class SweepSpec:
    """Everything a sweep's numbers depend on (stored with the dataset)."""

    hinge_sets: tuple[str, ...] = ("05-03", "03-03")
    phi1: Grid = Grid(5.0, 33.0, 41)           # to just past the side links' limit, 32.86 deg
    phi2: Grid = Grid(4.0, 56.0, 41)
    target_output_mm: float = 1.0
    base: dict = field(default_factory=dict)   # Design fields other than angles and hinges
    monte_carlo: int = 0
    hinge_sd_mm: float = 0.0
    seed: int = 0
    law: StrainEnergyLaw = DEFAULT_LAW         # hysteresis from strain energy (section 6.2.5)

    def __post_init__(self):
        if not (isinstance(self.hinge_sets, tuple) and self.hinge_sets):
            raise SweepError(f"hinge_sets = {self.hinge_sets!r}: must be a non-empty tuple of "
                             f"hinge set names ({', '.join(HINGE_SETS)})")
        for h in self.hinge_sets:
            if not (isinstance(h, str) and h in HINGE_SETS):
                raise SweepError(f"hinge set {h!r}: must be one of {', '.join(HINGE_SETS)}")
        for name, grid in (("phi1", self.phi1), ("phi2", self.phi2)):
            if not isinstance(grid, Grid):
                raise SweepError(f"{name} = {grid!r}: must be a Grid (START:STOP:N)")
            grid.validated(name)
        for name, rule in SPEC_RULES.items():  # numpy scalars become the plain numbers they hold
            object.__setattr__(self, name, rule.check(name, getattr(self, name), SweepError))
        cells = len(self.hinge_sets) * self.phi1.n * (self.phi2.n + 1)
        if cells > MAX_CELLS or cells * max(1, self.monte_carlo) > MAX_SOLVES:
            raise SweepError(f"sweep size = {len(self.hinge_sets)} hinge sets x {self.phi1.n} x "
                             f"{self.phi2.n} cells x {max(1, self.monte_carlo)} draws: must be at most "
                             f"{MAX_CELLS} cells and {MAX_SOLVES:.0e} solves")
        if self.monte_carlo and not self.hinge_sd_mm > 0:
            raise SweepError(f"hinge_sd_mm = {self.hinge_sd_mm!r}: must be > 0 mm when monte_carlo > 0")
        if not isinstance(self.law, StrainEnergyLaw):
            raise SweepError(f"law = {self.law!r}: must be a StrainEnergyLaw")
        if not isinstance(self.base, dict):
            raise SweepError(f"base = {self.base!r}: must be a dict of design fields")
        try:
            size = self.design("05-03", 20.0, None).height_mm  # the base fields make a valid design
        except GeometryError as exc:
            raise SweepError(f"base design: {exc}") from None
        if not Number(0.0, size, lo_open=True).ok(self.target_output_mm):
            raise SweepError(f"target_output_mm = {self.target_output_mm!r}: must be a positive number "
                             f"of mm, at most the body's height {size:g} mm")

    def design(self, hinges: str, phi1: float, phi2: float | None) -> Design:
        base = {k: v for k, v in self.base.items() if k not in ("phi1_deg", "phi2_deg", "hinge_set", "hinge_thickness_mm", "name")}
        return design_from_dict({**base, "phi1_deg": float(phi1), "phi2_deg": None if phi2 is None else float(phi2),
                                 "hinge_set": hinges, "hinge_thickness_mm": hinge_set_thicknesses(hinges),
                                 "name": f"{hinges}-{phi1:g}-{phi2}"}, source="sweep design")

    def family_thickness_mm(self) -> np.ndarray:
        """Hinge thicknesses (mm) of the basis family, from the base design's min_feature_mm."""
        t0 = self.design(self.hinge_sets[0], 20.0, None).min_feature_mm
        return np.geomspace(t0, FAMILY_SPAN * t0, FAMILY_POINTS)

    def family_design(self, phi1: float, thickness_mm: float) -> Design:
        """The basis body at ``phi1`` with hinges 1-8 ``thickness_mm`` thick (9-12 unused)."""
        d = self.design(self.hinge_sets[0], phi1, None)
        n = len(d.used_hinges)
        return d.replace(hinge_thickness_mm=(float(thickness_mm),) * n + d.hinge_thickness_mm[n:],
                         hinge_set="basis-family", name=f"basis-{phi1:g}-{thickness_mm:.4g}")

    def to_json(self) -> str:
        d = dataclasses.asdict(self)
        return json.dumps(d, sort_keys=True, default=str)
