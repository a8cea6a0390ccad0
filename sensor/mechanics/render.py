"""The 3D picture of a solved design: the extruded profile warped by the solved beam model,
coloured by strain energy density (``dacm render``).

From beam model to displacement field. Every point of the body belongs to one part of the
layout (:func:`geometry.layout.make_parts`, the parts the CAD profile is the union of):

* the base plate and the fiber post move rigidly with a model node of their rigid body:
  x = x_n + R(theta_n) (X - X_n);
* a hinge, a link, or a half of the top plate, the platform or a knee block follows its
  compliant member from node a to node b. In the member's chord frame (chord rotation
  alpha, end rotations theta_a' = theta_a - alpha and theta_b' = theta_b - alpha relative
  to the chord, as in the solver) the centre line at
  xi = s / L0 is stretched uniformly (constant N) and deflected by the cubic Hermite
  interpolation of the end rotations,
  w(xi) = L [(xi - 2 xi^2 + xi^3) theta_a' + (xi^3 - xi^2) theta_b'],
  the Euler-Bernoulli deflection of a member loaded only at its ends (linear moment,
  shear deflection left out); each cross-section turns with the slope, alpha + w'(xi).
  At xi = 0 and 1 this is the rigid motion of the end node, so the field is continuous
  from body to hinge to link.

The picture shows the field magnified by a displacement scale factor (stated in it):
x = X + scale u(X). A magnification never draws one rigid part through another (the
platform through the fiber post, say): the automatic scale steps down until none that are
apart at rest overlap, and an explicit one that would is refused. The strain energy density (mJ/mm^3) of a member is U / (L0 t b), with U
the member's strain energy from the solver (eqs 80-82); rigid parts carry none.

Lengths mm, forces N, energies mJ. VTK renders off-screen (EGL), no display needed.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from geometry.layout import Part
from geometry.params import Design
from geometry.topology import BeamModel
from sensor.errors import SensorInputError
from sensor.mechanics.solver import SolveResult, prepare

#: Distance (mm) within which a point counts as on a part, or a node as on a part's outline:
#: the CAD tessellation reproduces the straight-edged profile to rounding (about 1e-12 mm).
ON_PART_TOL_MM = 1e-6

#: The automatic scale magnifies the largest displacement to this fraction of the body's
#: larger footprint dimension, rounded down to 1, 2 or 5 x 10^k and never below 1 (and
#: lowered further while it would draw rigid parts through each other).
AUTO_SCALE_FRACTION = 0.08

#: Mesh edge length as a fraction of the hinge length: about 10 segments bend each hinge.
EDGE_PER_HINGE_LENGTH = 0.1

#: The colour bar spans this many decades of strain energy density below the largest.
COLOUR_DECADES = 4

#: Colour of the rigid parts (no strain energy), a blue-grey outside the colour map.
RIGID_COLOUR = "#b8c4d0"

#: Where the body sits across the picture (fraction of its width; the colour bar is right).
BODY_CENTRE_X = 0.43

_PRIORITY = {"plate": 0, "block": 0, "platform": 0, "post": 0, "hinge": 1, "link": 2}


@dataclass(frozen=True)
class PartMotion:
    """How one layout part moves: rigidly with model ``node`` (``member`` = -1), or with the
    compliant ``member`` whose axis runs from node ``start`` to node ``end``."""

    node: int
    member: int
    start: int
    end: int


# --- parts of the layout and the beam model -------------------------------------------------

def _edge_normals(polygon: np.ndarray) -> np.ndarray:
    """Outward unit normals (k, 2) of the edges of a convex counter-clockwise polygon."""
    edge = np.roll(polygon, -1, axis=0) - polygon
    return np.column_stack([edge[:, 1], -edge[:, 0]]) / np.linalg.norm(edge, axis=1)[:, None]


def polygon_distance(polygon: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Signed distance-like measure (mm) of points (P, 2) from a convex CCW polygon: the
    largest distance beyond an edge line; < 0 inside, 0 on the outline, > 0 outside."""
    normal = _edge_normals(polygon)
    offset = np.sum(polygon * normal, axis=1)
    x, y = points[:, 0], points[:, 1]
    return np.maximum.reduce([x * nx + y * ny - c for (nx, ny), c in zip(normal, offset)])


def _overlap(p: np.ndarray, q: np.ndarray) -> bool:
    """Whether two convex polygons share interior (no edge normal separates them)."""
    for n in np.vstack([_edge_normals(p), _edge_normals(q)]):
        a, b = p @ n, q @ n
        if a.max() <= b.min() + ON_PART_TOL_MM or b.max() <= a.min() + ON_PART_TOL_MM:
            return False
    return True


def assign_parts(parts: list[Part], points: np.ndarray) -> np.ndarray:
    """Index (P,) of the part each point (P, 2) belongs to.

    A point on or in a rigid part belongs to it (hinge roots reach into their bodies), else
    to a hinge, else to a link containing it; a point outside every part (tessellation
    rounding only) to the nearest.
    """
    dist = np.column_stack([polygon_distance(p.polygon, points) for p in parts])
    rank = np.array([_PRIORITY[p.kind] for p in parts], dtype=float)
    key = np.where(dist <= ON_PART_TOL_MM, rank[None, :], len(_PRIORITY) + dist)
    return np.argmin(key, axis=1)


def part_motions(parts: list[Part], model: BeamModel) -> list[PartMotion]:
    """The node or member of the beam model that moves each part.

    A hinge or link follows the compliant member that lies along its axis (a hinge: the one
    with its hinge number), whatever the member's reach past the axis ends. A rigid
    part follows the model nodes on its outline, which must belong to one rigid body (or
    all be held by supports); a part with no node on it (the fiber post) moves with a rigid
    part it overlaps. Raises :class:`SensorError` when model and layout do not match.
    """
    topo = prepare(model)
    body, free = topo.body_of_node, topo.free_body
    motions: list[PartMotion | None] = [None] * len(parts)
    flex = [m for m, k in enumerate(model.member_kind) if k != "rigid"]
    for i, p in enumerate(parts):
        if p.axis is None:
            continue
        for m in flex:
            a, b = (int(v) for v in model.member_nodes[m])
            if p.hinge and model.hinge_number[m] != p.hinge:
                continue
            ends = model.nodes[[a, b]]
            if not _on_axis(ends, p.axis):
                continue
            forward = np.dot(ends[1] - ends[0], p.axis[1] - p.axis[0]) > 0
            motions[i] = PartMotion(-1, m, a, b) if forward else PartMotion(-1, m, b, a)
        if motions[i] is None:
            raise SensorInputError(f"layout part {p.name!r} matches no compliant member of the beam "
                              "model: model and design do not match")
    rigid = [i for i, p in enumerate(parts) if p.axis is None]
    for i in rigid:
        on = np.flatnonzero(polygon_distance(parts[i].polygon, model.nodes) <= ON_PART_TOL_MM)
        moving = {int(body[n]) for n in on if free[body[n]]}
        if len(moving) > 1 or (moving and len(moving) != len({int(body[n]) for n in on})):
            raise SensorInputError(f"layout part {parts[i].name!r} touches nodes of different rigid "
                              "bodies of the beam model: model and design do not match")
        if len(on):
            motions[i] = PartMotion(int(on[0]), -1, -1, -1)
    for i in rigid:
        if motions[i] is None:
            j = next((j for j in rigid if motions[j] is not None
                      and _overlap(parts[i].polygon, parts[j].polygon)), None)
            if j is None:
                raise SensorInputError(f"layout part {parts[i].name!r} is attached to no node of the "
                                  "beam model")
            motions[i] = motions[j]
    return motions


# --- the displacement field -----------------------------------------------------------------

def _wrap(a):
    """Angle(s) wrapped to [-pi, pi)."""
    return (a + np.pi) % (2 * np.pi) - np.pi


def _rigid(X: np.ndarray, Xn: np.ndarray, un: np.ndarray, th: float) -> np.ndarray:
    """Displacement (P, 2) of points X moving rigidly with a node: u_n + (R - I)(X - X_n)."""
    r = X - Xn
    s, cm1 = math.sin(th), -2.0 * math.sin(th / 2) ** 2   # cos - 1 without cancellation
    return un + np.column_stack([cm1 * r[:, 0] - s * r[:, 1], s * r[:, 0] + cm1 * r[:, 1]])


def _member(X: np.ndarray, Xa, Xb, xa, xb, tha: float, thb: float) -> np.ndarray:
    """Displacement (P, 2) of points X of a member from node a to b (module docstring)."""
    L0 = float(np.linalg.norm(Xb - Xa))
    u0 = (Xb - Xa) / L0
    n0 = np.array([-u0[1], u0[0]])
    s = (X - Xa) @ u0
    h = (X - Xa) @ n0
    xi = np.clip(s / L0, 0.0, 1.0)
    e = s - xi * L0                                   # beyond an end: carried rigidly
    d = xb - xa
    L = float(np.linalg.norm(d))
    e1 = d / L
    e2 = np.array([-e1[1], e1[0]])
    alpha = _wrap(math.atan2(d[1], d[0]) - math.atan2(u0[1], u0[0]))
    ta, tb = _wrap(tha - alpha), _wrap(thb - alpha)
    w = L * ((xi - 2 * xi**2 + xi**3) * ta + (xi**3 - xi**2) * tb)
    psi = (1 - 4 * xi + 3 * xi**2) * ta + (3 * xi**2 - 2 * xi) * tb
    c, sn = np.cos(psi), np.sin(psi)
    along = xi * L + c * e - sn * h                   # in the chord frame (e1, e2)
    across = w + sn * e + c * h
    return xa + along[:, None] * e1 + across[:, None] * e2 - X


def displacement_field(points: np.ndarray, parts: list[Part], motions: list[PartMotion],
                       model: BeamModel, result: SolveResult) -> np.ndarray:
    """Displacement (P, 2) mm of in-plane points (P, 2) of the body in the solved state."""
    X0, x = model.nodes, result.deformed_nodes
    th = result.node_rotation_rad
    owner = assign_parts(parts, points)
    u = np.zeros_like(points, dtype=float)
    for i, mo in enumerate(motions):
        sel = owner == i
        if not sel.any():
            continue
        if mo.member < 0:
            u[sel] = _rigid(points[sel], X0[mo.node], x[mo.node] - X0[mo.node], float(th[mo.node]))
        else:
            # a hinge member reaches past its drawn neck into the bodies it joins (see
            # geometry.topology.root_depth_mm): its end states are carried rigidly
            # back to the part's own axis ends, so neighbouring parts meet exactly
            a, b = mo.start, mo.end
            A, B = _inner_ends(parts[i].axis, X0[a], X0[b])
            xa = A + _rigid(A[None], X0[a], x[a] - X0[a], float(th[a]))[0]
            xb = B + _rigid(B[None], X0[b], x[b] - X0[b], float(th[b]))[0]
            u[sel] = _member(points[sel], A, B, xa, xb, float(th[a]), float(th[b]))
    return u


def _inner_ends(axis: np.ndarray, Xa: np.ndarray, Xb: np.ndarray):
    """The member's ends (Xa, Xb), each moved back onto the part's axis end where the
    member reaches past it."""
    A, B = axis
    u = (B - A) / np.linalg.norm(B - A)
    return (A if (Xa - A) @ u < 0 else Xa), (B if (Xb - B) @ u > 0 else Xb)


def _on_axis(ends: np.ndarray, axis: np.ndarray) -> bool:
    """Whether a member's end points (2, 2) lie on a part's axis line and the two spans
    overlap (a member may reach past its part's ends, or stop short of them)."""
    A, B = axis
    L = float(np.linalg.norm(B - A))
    u = (B - A) / L
    n = np.array([-u[1], u[0]])
    if np.abs((ends - A) @ n).max() > ON_PART_TOL_MM:
        return False
    s = np.sort((ends - A) @ u)
    return s[0] < L / 2 < s[1] and (s[0] + s[1]) / 2 > 0 and (s[0] + s[1]) / 2 < L


def member_strain_energy(model: BeamModel, result: SolveResult) -> np.ndarray:
    """Strain energy (mJ) of every model member, as the solver computed it; zero if rigid."""
    U = np.zeros(len(model.member_kind))
    U[result.member_index] = result.member_strain_energy_mJ
    return U


def strain_energy_density(model: BeamModel, result: SolveResult) -> np.ndarray:
    """Strain energy density (mJ/mm^3) of every model member: U / (L0 t b); zero if rigid."""
    U = member_strain_energy(model, result)
    volume = model.lengths_mm * model.thickness_mm * model.depth_mm
    return np.where(U > 0, U / np.where(volume > 0, volume, 1.0), 0.0)


def auto_scale(max_displacement_mm: float, size_mm: float) -> float:
    """Displacement scale showing the largest displacement as AUTO_SCALE_FRACTION of the
    body size: rounded down to 1, 2 or 5 x 10^k, at least 1."""
    if not max_displacement_mm > 0:
        return 1.0
    ideal = AUTO_SCALE_FRACTION * size_mm / max_displacement_mm
    if ideal <= 1.0:
        return 1.0
    k = math.floor(math.log10(ideal))
    return max(m * 10.0**k for m in (1, 2, 5) if m * 10.0**k <= ideal)


# --- the mesh and the picture -------------------------------------------------------------

def body_mesh(design: Design):
    """The extruded body (pyvista PolyData, mm) from the checked CAD tessellation, its
    triangles subdivided to edges of at most EDGE_PER_HINGE_LENGTH x hinge length."""
    import pyvista as pv

    from geometry.export import checked_mesh

    mesh = pv.wrap(checked_mesh(design))
    return mesh.subdivide_adaptive(max_edge_len=EDGE_PER_HINGE_LENGTH * design.hinge_length_mm)


def _step_down(scale: float) -> float:
    """The next smaller value of the 1, 2, 5 x 10^k sequence."""
    k = math.floor(math.log10(scale) + 1e-9)
    m = scale / 10.0**k
    return (5.0 if m > 5 + 1e-9 else 2.0 if m > 2 + 1e-9 else 1.0 if m > 1 + 1e-9 else 0.5) * 10.0**k


def rigid_outlines(parts: list[Part], motions: list[PartMotion], model: BeamModel,
                   result: SolveResult) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """(name, outline at rest (k, 2), displacement of its corners (k, 2)) of every rigid
    part, and of the plate, platform and knee halves, which bend a little with their members
    (their corners follow the member's field)."""
    X0, x, th = model.nodes, result.deformed_nodes, result.node_rotation_rad

    def moved(p, mo):
        if mo.member < 0:
            return _rigid(p.polygon, X0[mo.node], x[mo.node] - X0[mo.node], float(th[mo.node]))
        a, b = mo.start, mo.end
        return _member(p.polygon, X0[a], X0[b], x[a], x[b], float(th[a]), float(th[b]))

    return [(p.name, p.polygon, moved(p, mo)) for p, mo in zip(parts, motions)
            if mo.member < 0 or p.kind in ("plate", "platform", "block")]


def overlapping_parts(outlines, scale: float) -> list[tuple[str, str]]:
    """Pairs of rigid parts apart at rest whose outlines overlap when the displacements are
    magnified by ``scale`` (a rigid motion magnified is still an affine map of the outline)."""
    pairs = []
    for i, (name_a, a, ua) in enumerate(outlines):
        for name_b, b, ub in outlines[i + 1:]:
            if not _overlap(a, b) and _overlap(a + scale * ua, b + scale * ub):
                pairs.append((name_a, name_b))
    return pairs


def picture_scale(outlines, max_displacement_mm: float, size_mm: float,
                  scale: float | None = None) -> float:
    """The displacement scale of the picture: ``scale`` if given, else :func:`auto_scale`
    stepped down (1, 2, 5 x 10^k) until no rigid parts apart at rest overlap, never below 1.

    Raises :class:`SensorInputError` for a given scale above 1 that draws parts through
    each other which do not touch at true scale.
    """
    if scale is not None:
        hits = overlapping_parts(outlines, scale)
        if scale > 1 and hits and not overlapping_parts(outlines, 1.0):
            safe = picture_scale(outlines, max_displacement_mm, size_mm, None)
            raise SensorInputError(
                f"scale = {scale:g}: the magnified displacements draw the {hits[0][0]} through "
                f"the {hits[0][1]}; use at most the automatic {safe:g} (omit --scale)")
        return float(scale)
    s = auto_scale(max_displacement_mm, size_mm)
    while s > 1 and overlapping_parts(outlines, s):
        s = max(_step_down(s), 1.0)
    return s


@dataclass(frozen=True)
class RenderedBody:
    """What the picture shows: the undeformed mesh, the displacement of its points (mm), the
    strain energy density of its cells (mJ/mm^3) and the displacement scale used."""

    mesh: object                  # pyvista PolyData, undeformed
    displacement: np.ndarray      # (P, 2) mm
    cell_sed: np.ndarray          # (C,) mJ/mm^3
    scale: float


def deformed_body(design: Design, model: BeamModel, result: SolveResult, parts: list[Part],
                  scale: float | None = None) -> RenderedBody:
    """Mesh the body and evaluate the solved displacement and strain energy density on it;
    the displacement scale is :func:`picture_scale`."""
    mesh = body_mesh(design)
    motions = part_motions(parts, model)
    pts = np.asarray(mesh.points[:, :2], dtype=float)
    u = displacement_field(pts, parts, motions, model, result)
    sed_member = strain_energy_density(model, result)
    sed_part = np.array([0.0 if mo.member < 0 else sed_member[mo.member] for mo in motions])
    centres = np.asarray(mesh.cell_centers().points[:, :2], dtype=float)
    cell_sed = sed_part[assign_parts(parts, centres)]
    scale = picture_scale(rigid_outlines(parts, motions, model, result),
                          float(np.linalg.norm(u, axis=1).max()),
                          max(design.width_mm, design.height_mm), scale)
    return RenderedBody(mesh, u, cell_sed, scale)


def _use_offscreen_gl() -> None:
    """Without an X display, ask VTK for its EGL window directly (no X warning)."""
    if not os.environ.get("DISPLAY"):
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")


def _shift_left(camera, window_size: tuple[int, int], centre_x: float) -> None:
    """Pan a parallel-projection camera so the scene centre sits at ``centre_x`` of the
    picture width (room for the colour bar on the right)."""
    forward = np.subtract(camera.focal_point, camera.position)
    right = np.cross(forward, camera.up)
    right /= np.linalg.norm(right)
    half_width = camera.parallel_scale * window_size[0] / window_size[1]
    step = right * (0.5 - centre_x) * 2 * half_width
    camera.position = tuple(np.add(camera.position, step))
    camera.focal_point = tuple(np.add(camera.focal_point, step))


def render_png(body: RenderedBody, path: str | Path, title: str, subtitle: str,
               window_size: tuple[int, int] = (1600, 1200)) -> None:
    """Draw the undeformed body (faint grey with grey outlines) and the deformed body
    coloured by strain energy density (log scale, COLOUR_DECADES decades, rigid parts in
    blue-grey) off-screen, looking at the profile from slightly above and to the side so
    the sheet thickness shows, and save a PNG at ``path``."""
    _use_offscreen_gl()
    import pyvista as pv

    pv.OFF_SCREEN = True
    mesh = body.mesh.copy()
    warped = mesh.copy()
    warped.points[:, :2] += body.scale * body.displacement
    warped.cell_data["sed"] = np.where(body.cell_sed > 0, body.cell_sed, np.nan)
    top = float(body.cell_sed.max())
    hi = 10.0 ** math.ceil(math.log10(top)) if top > 0 else 1.0
    edges = dict(feature_angle=30, boundary_edges=False, non_manifold_edges=False,
                 manifold_edges=False)

    k = min(window_size[0] / 1600, window_size[1] / 1200) ** 0.5   # font size factor
    p = pv.Plotter(off_screen=True, window_size=list(window_size))
    try:
        p.set_background("white")
        p.add_mesh(mesh, color="#b0b0b0", opacity=0.15, lighting=False)
        p.add_mesh(mesh.extract_feature_edges(**edges), color="#8c8c8c", line_width=1.0)
        p.add_mesh(warped, scalars="sed", preference="cell", cmap="plasma", log_scale=True,
                   clim=[hi / 10.0**COLOUR_DECADES, hi], nan_color=RIGID_COLOUR,
                   scalar_bar_args=dict(title="strain energy\ndensity (mJ/mm³)\n", fmt="%.0e",
                                        n_labels=COLOUR_DECADES + 1, nan_annotation=True,
                                        vertical=True, position_x=0.85, position_y=0.2,
                                        width=0.05, height=0.6, color="black",
                                        title_font_size=round(18 * k),
                                        label_font_size=round(16 * k)))
        p.scalar_bar.SetNanAnnotation("rigid")
        p.add_mesh(warped.extract_feature_edges(**edges), color="black", line_width=1.0)
        p.add_text(f"{title}\n{subtitle}", position="upper_left", font_size=round(15 * k),
                   color="black")
        p.enable_parallel_projection()
        p.view_xy()
        p.camera.Azimuth(-18)
        p.camera.Elevation(15)
        p.reset_camera()
        p.camera.zoom(1.08)
        _shift_left(p.camera, window_size, BODY_CENTRE_X)
        img = p.screenshot(None, return_img=True)
    finally:
        p.close()
    if img is None or img.std() == 0:
        raise SensorInputError("the off-screen renderer produced a blank picture (is libEGL/Mesa "
                          "installed?)")
    import imageio.v3 as iio

    from geometry.atomic import atomic_path

    with atomic_path(path) as tmp:  # checked first, written whole: never a blank or partial file
        iio.imwrite(tmp, img, extension=".png")
