"""One hinge between a block and a link, in plane stress: the substructure the root rule
(geometry.topology.root_depth_mm) describes, as a continuum reference independent of the
beam model.

A neck of thickness t leaves the top face of a block (16 mm wide, 6 mm deep unless said
otherwise, its bottom edge clamped)
along an axis that leans ``gamma_deg`` from the face's normal, runs the drawn neck length
(measured along the axis from where it crosses the face) and enters a link 2 mm wide
square to it, whose end lies 5 mm further on. Every re-entrant corner is rounded with the
jet's radius r (a morphological closing of the outline). Loads on the link's end: an axial
force, a transverse force and a moment, as tractions (uniform, uniform, linear across);
the compliance is the work-conjugate one, C_jk = int traction_j . u_k ds per unit load
(symmetric by Betti). Quadratic triangles (scikit-fem), elements of min(t, r) / n_across
at the neck, growing away from it (gmsh).

The beam side is the model's own hinge member (geometry.topology.hinge_profile, its
flexibility by sensor.mechanics.solver.profile_flexibility, with the axial compliance of
geometry.topology.axial_spread) carried rigidly from the block's effective root to the link,
and the rest of the link as a cantilever.
"""

import math

import numpy as np

from geometry.topology import axial_spread, hinge_profile
from sensor.mechanics.continuum import gmsh_session, mesh_surface
from sensor.mechanics.solver import cantilever_flexibility, profile_flexibility

E_MPA, NU = 1000.0, 0.35
G_MPA = E_MPA / (2 * (1 + NU))
BLOCK_MM = (16.0, 6.0)     # width, depth (the bottom edge clamped)
LINK_MM = (2.0, 5.0)       # width, length past the neck


def _axes(gamma_deg):
    g = math.radians(gamma_deg)
    u = np.array([math.sin(g), math.cos(g)])   # along the neck, away from the block
    return u, np.array([-u[1], u[0]])           # and across it


def outline(t, neck_mm, gamma_deg, r, link_mm=LINK_MM[1], depth_mm=BLOCK_MM[1]):
    """The substructure's outline (shapely Polygon, mm; the neck's axis crosses the block's
    face at the origin; the block ``depth_mm`` deep)."""
    from shapely.geometry import Polygon, box
    from shapely.ops import unary_union

    u, v = _axes(gamma_deg)

    def strip(s0, s1, w):
        return Polygon([s0 * u + v * w / 2, s1 * u + v * w / 2, s1 * u - v * w / 2, s0 * u - v * w / 2])

    bw, bd, lw = BLOCK_MM[0], depth_mm, LINK_MM[0]
    # the neck's strip runs 2 t into the block and t into the link (both cover it there):
    # ending it on the link's edge left a zero-width spike in the union at some angles
    # (gamma 20 deg), which gmsh could not mesh
    shape = unary_union([box(-bw / 2, -bd, bw / 2, 0.0), strip(-2 * t, neck_mm + t, t),
                         strip(neck_mm, neck_mm + link_mm, lw)])
    if r > 0:  # closing: re-entrant corners rounded with r, convex ones kept sharp (mitred)
        shape = shape.buffer(r, join_style="mitre", mitre_limit=10.0).buffer(-r, quad_segs=48)
    return shape.simplify(1e-5)


def plane_stress_polygon(name: str, xy, size):
    """Quadratic triangles (scikit-fem) of the polygon ``xy`` (N, 2) mm, meshed by gmsh at
    element size ``size(x, y)`` mm: the mesh, its vector basis and the plane-stress
    stiffness (unit depth, E_MPA, NU)."""
    from skfem import Basis, ElementTriP2, ElementVector, MeshTri, asm
    from skfem.models.elasticity import linear_elasticity

    from sensor.mechanics.continuum import _lame

    with gmsh_session(name) as gmsh:
        geo = gmsh.model.geo
        pts = [geo.addPoint(float(x), float(y), 0.0) for x, y in xy]
        lines = [geo.addLine(pts[i], pts[(i + 1) % len(pts)]) for i in range(len(pts))]
        geo.addPlaneSurface([geo.addCurveLoop(lines)])
        geo.synchronize()
        points, tri = mesh_surface(size)
    mesh = MeshTri(np.ascontiguousarray(points.T), np.ascontiguousarray(tri.T))
    basis = Basis(mesh, ElementVector(ElementTriP2()), intorder=4)
    return mesh, basis, asm(linear_elasticity(*_lame(E_MPA, NU, plane_strain=False)), basis)


def fe_compliance(t, neck_mm, gamma_deg, r, n_across=6.0, link_mm=None, depth_mm=BLOCK_MM[1]):
    """Plane-stress compliance (3, 3) of the link's end, unit depth: [axial, transverse,
    rotation] per [axial force, transverse force, moment] (mm/N, rad/(N mm)), loads along
    and across the neck's axis, the moment counter-clockwise; the block ``depth_mm`` deep."""
    from skfem import FacetBasis, LinearForm, asm, condense, solve

    lw, ll = LINK_MM[0], link_mm or LINK_MM[1]
    u, v = _axes(gamma_deg)
    end = (neck_mm + ll) * u
    h = (min(t, r) if r > 0 else t) / n_across

    def size(x, y):
        p = np.array([x, y])
        s = float(np.clip(p @ u, 0.0, neck_mm))
        return float(min(h + 0.35 * max(np.linalg.norm(p - s * u) - t, 0.0), lw / 3))

    xy = np.array(outline(t, neck_mm, gamma_deg, r, ll, depth_mm).exterior.coords)[:-1]
    mesh, basis, K = plane_stress_polygon("hinge", xy, size)
    fixed = basis.get_dofs(mesh.facets_satisfying(lambda x: x[1] < -depth_mm + 1e-7, boundaries_only=True)).all()
    facets = mesh.facets_satisfying(lambda x: np.abs((x[0] - end[0]) * u[0] + (x[1] - end[1]) * u[1]) < 1e-6,
                                    boundaries_only=True)
    fb = FacetBasis(mesh, basis.elem, facets=facets, intorder=4)
    inertia = lw**3 / 12
    # each load: its direction and its traction (N/mm per unit load) at xi across the end
    loads = ((u, lambda xi: np.full_like(xi, 1.0 / lw)),      # axial force
             (v, lambda xi: np.full_like(xi, 1.0 / lw)),      # transverse force
             (u, lambda xi: -xi / inertia))                   # moment: sigma = -M xi / I

    def assemble(direction, traction):
        @LinearForm
        def form(w, p):
            xi = (p.x[0] - end[0]) * v[0] + (p.x[1] - end[1]) * v[1]
            return traction(xi) * (direction[0] * w[0] + direction[1] * w[1])
        return asm(form, fb)

    F = np.column_stack([assemble(*load) for load in loads])
    U = np.column_stack([solve(*condense(K, F[:, k], D=fixed)) for k in range(3)])
    return F.T @ U


def beam_compliance(t, neck_mm, gamma_deg, r, depth_mm=BLOCK_MM[1]):
    """The beam model's compliance of the same end (see :func:`fe_compliance`)."""
    lw, ll = LINK_MM
    ends = ((r, math.inf, gamma_deg, depth_mm), (r, (lw - t) / 2, 0.0, lw))  # the block's face is long
    stations, _, length, behind, _ = hinge_profile(t, neck_mm, ends)
    # the neck leans towards +x: its acute corner, where the centroid moves, is on the right
    hinge = profile_flexibility(np.asarray(stations) * (1.0, 1.0, -1.0), 1.0, E_MPA, G_MPA)
    hinge[0, 0] += axial_spread(t, r, depth_mm) / E_MPA  # the block is clamped depth_mm behind its face
    rest = neck_mm + ll - (length - behind)          # the link past the hinge member's end
    carry = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, rest, 1.0]])  # end loads at the member's tip
    return cantilever_flexibility(rest, lw, 1.0, E_MPA, G_MPA) + carry.T @ hinge @ carry
