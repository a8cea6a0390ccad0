"""The sensor as a susceptibility map: its body, fiber and mirror voxelised in a medium.

- The body: the checked triangle mesh of the design's extruded profile
  (:func:`geometry.export.checked_mesh`), in its material (``Material.chi_ppm``, or any
  named material for comparisons).
- The fiber: a cylinder of :data:`~sensor.artefact.susceptibility.FIBER_DIAMETER_MM` along
  the force axis y, in the sheet's mid-plane, from the tip at the top of the fiber post
  (``Layout.post_top``) down through the post and the base plate and out of the field of
  view (it runs to the console, metres away).
- The mirror: a square slab under the output (``Layout.output_point``: the platform, or the
  top plate of the basis body), as wide as the platform and at most the sheet thick, recessed
  into it by its thickness so the fiber-mirror gap stays ``fiber_clearance_mm``.

Fiber and mirror replace the body where they overlap it. Lengths in mm; the frame is the
layout's (x across, y up from the base, z through the sheet, 0 to its thickness).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

from geometry.checks import assert_feasible
from geometry.export import checked_mesh
from geometry.layout import make_layout
from geometry.params import Design
from sensor.artefact.susceptibility import (
    FIBER_DIAMETER_MM,
    FIBER_MATERIAL,
    MEDIA,
    MIRROR_LAYERS_MM,
    body_chi_ppm,
    check_chi,
    chi_ppm,
    layered_chi_ppm,
)
from sensor.artefact.voxels import Grid, grid_around, occupancy
from sensor.errors import ArtefactError

#: Default field-model voxel (mm) and the margin (mm) of water or air around the sensor.
RESOLUTION_MM, MARGIN_MM = 0.5, 30.0

#: Facets of the fiber's cylinder mesh.
_FIBER_SECTIONS = 48


@dataclass(frozen=True)
class SolidPart:
    """One solid of the sensor: a closed mesh and its susceptibility (SI, ppm)."""

    name: str
    mesh: trimesh.Trimesh
    chi_ppm: float


@dataclass(frozen=True)
class Scene:
    """The voxelised sensor: ``chi_ppm`` (absolute, SI ppm) and ``solid`` (the fraction of
    each voxel that is sensor, not medium), both float32 on ``grid``, and ``beyond_hull``,
    the voxels wholly outside the body's convex hull (not in the mechanism's openings)."""

    grid: Grid
    chi_ppm: np.ndarray
    solid: np.ndarray
    beyond_hull: np.ndarray
    medium: str
    chi_medium_ppm: float
    parts: tuple[tuple[str, float], ...]

    @property
    def delta_chi_ppm(self) -> np.ndarray:
        return self.chi_ppm - np.float32(self.chi_medium_ppm)


def mirror_box(design: Design) -> tuple[np.ndarray, np.ndarray]:
    """Lowest and highest corner (mm) of the mirror slab."""
    lay = make_layout(design)
    side = min(design.platform_width_mm, design.sheet_thickness_mm)
    thick = min(sum(t for _, t in MIRROR_LAYERS_MM), design.platform_thickness_mm)
    zc, y0 = design.sheet_thickness_mm / 2.0, float(lay.output_point[1])
    return np.array([-side / 2, y0, zc - side / 2]), np.array([side / 2, y0 + thick, zc + side / 2])


def sensor_parts(design: Design, fiber_bottom_mm: float, body_material: str | None = None) -> list[SolidPart]:
    """The body, the fiber (from ``fiber_bottom_mm`` up to its tip) and the mirror.
    ``body_material`` names another material for the body (e.g. "aluminium")."""
    chi_body = body_chi_ppm(design.material) if body_material is None else chi_ppm(body_material)
    check_chi("body chi_ppm", chi_body)
    lay = make_layout(design)
    zc = design.sheet_thickness_mm / 2.0
    fiber = trimesh.creation.cylinder(radius=FIBER_DIAMETER_MM / 2.0, sections=_FIBER_SECTIONS,
                                      segment=[[0.0, fiber_bottom_mm, zc], [0.0, float(lay.post_top), zc]])
    lo, hi = mirror_box(design)
    mirror = trimesh.creation.box(bounds=np.array([lo, hi]))
    return [SolidPart("body", checked_mesh(design), chi_body),
            SolidPart("fiber", fiber, chi_ppm(FIBER_MATERIAL)),
            SolidPart("mirror", mirror, layered_chi_ppm(MIRROR_LAYERS_MM))]


def sensor_scene(design: Design, medium: str = "water", resolution_mm: float = RESOLUTION_MM,
                 margin_mm: float = MARGIN_MM, multiple: int = 1,
                 body_material: str | None = None) -> Scene:
    """Voxelise the sensor at ``resolution_mm`` in a box ``margin_mm`` larger than the body on
    every side (each side a whole number of ``multiple`` voxels, for image blocks)."""
    if medium not in MEDIA:
        raise ArtefactError(f"medium = {medium!r}: must be one of {', '.join(MEDIA)}")
    assert_feasible(design)  # a body that cannot be cut has no artefact to predict
    body = checked_mesh(design)
    grid = grid_around(body.bounds, margin_mm, resolution_mm, multiple)
    parts = sensor_parts(design, grid.lower_mm[1] - 2.0 * resolution_mm, body_material)
    frac = {p.name: occupancy(p.mesh, grid) for p in parts}
    inserts = frac["fiber"] + frac["mirror"]
    body_frac = np.clip(frac["body"] - inserts, 0.0, 1.0)
    solid = np.clip(body_frac + inserts, 0.0, 1.0)
    chi_m = chi_ppm(medium)
    chi = np.float32(chi_m) * (1.0 - solid)
    for p in parts:
        chi += np.float32(p.chi_ppm) * (body_frac if p.name == "body" else frac[p.name])
    beyond_hull = occupancy(body.convex_hull, grid) == 0.0
    return Scene(grid, chi.astype(np.float32), solid.astype(np.float32), beyond_hull, medium, chi_m,
                 tuple((p.name, p.chi_ppm) for p in parts))
