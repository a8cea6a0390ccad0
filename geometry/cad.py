"""The CadQuery body of a design: the 2D profile face, its extrusion, and measurements on it.

The profile is the union of the convex parts of :func:`geometry.layout.make_parts` (plates,
knee blocks, links, hinge necks, platform, fiber post), so it is drawn from the same layout
as the beam model. Lengths in mm; the profile lies in the plane z = 0 and is extruded along
+z by the sheet thickness. Only this module and :mod:`geometry.export` import CadQuery.
"""

from __future__ import annotations

import math

import cadquery as cq
import numpy as np
from OCP.BRepAlgoAPI import BRepAlgoAPI_Common
from OCP.BRepClass import BRepClass_FaceClassifier
from OCP.BRepOffsetAPI import BRepOffsetAPI_MakeOffset
from OCP.GeomAbs import GeomAbs_Arc
from OCP.TopAbs import TopAbs_IN

from geometry.errors import GeometryError
from geometry.layout import Layout, Part, make_layout, make_parts
from geometry.params import Design

#: Half-length (mm) of the probe lines used to cut chords: longer than any footprint side.
_PROBE_MM = 1000.0


def _polygon_face(polygon: np.ndarray) -> cq.Face:
    pts = [cq.Vector(float(x), float(y), 0.0) for x, y in polygon]
    return cq.Face.makeFromWires(cq.Wire.makePolygon(pts, close=True))


def _contains(face: cq.Face, point: cq.Vector) -> bool:
    """Whether ``point`` lies strictly inside ``face``."""
    return BRepClass_FaceClassifier(face.wrapped, point.toPnt(), 1e-7).State() == TopAbs_IN


def _single_face(shape: cq.Shape, what: str) -> cq.Face:
    faces = shape.Faces()
    if len(faces) != 1:
        raise GeometryError(f"{what} is {len(faces)} separate pieces: must be one connected body")
    return faces[0]


def profile_face(design: Design, layout: Layout | None = None) -> cq.Face:
    """The 2D profile (one face with holes, z = 0, mm): the union of the layout's parts."""
    parts = make_parts(layout or make_layout(design))
    faces = [_polygon_face(p.polygon) for p in parts]
    union = faces[0].fuse(*faces[1:]).clean()
    return _single_face(union, f"the profile of design {design.name!r}")


def hole_count(face: cq.Face) -> int:
    """Number of through-holes (inner boundaries) of a profile face."""
    return len(face.innerWires())


def perimeter_mm(face: cq.Face) -> float:
    """Total boundary length (outline plus holes), mm."""
    return face.outerWire().Length() + sum(w.Length() for w in face.innerWires())


def offset_face(face: cq.Face, distance_mm: float) -> cq.Face:
    """The face grown by ``distance_mm`` (outline out, holes in; negative shrinks it).

    Convex corners are rounded with arcs (``GeomAbs_Arc``), as a round water jet leaves them.
    Raises :class:`GeometryError` if the offset splits the body or loses it.
    """
    maker = BRepOffsetAPI_MakeOffset(face.wrapped, GeomAbs_Arc)
    maker.Perform(float(distance_mm))
    if not maker.IsDone():
        raise GeometryError(f"offset of the profile by {distance_mm:g} mm failed")
    wires = cq.Shape.cast(maker.Shape()).Wires()
    if not wires:
        raise GeometryError(f"offset of the profile by {distance_mm:g} mm leaves nothing")
    fills = [cq.Face.makeFromWires(w) for w in wires]
    depth = [sum(_contains(fills[j], w.startPoint()) for j in range(len(wires)) if j != i)
             for i, w in enumerate(wires)]
    if depth.count(0) != 1 or max(depth) > 1:
        raise GeometryError(f"offset of the profile by {distance_mm:g} mm splits the body "
                            "into separate pieces")
    outer = wires[depth.index(0)]
    inner = [w for w, k in zip(wires, depth) if k == 1]
    result = cq.Face.makeFromWires(outer, inner)
    if not result.isValid():
        raise GeometryError(f"offset of the profile by {distance_mm:g} mm is not a valid face")
    return result


def extrude(face: cq.Face, thickness_mm: float) -> cq.Solid:
    """The prism of a profile face along +z, ``thickness_mm`` deep."""
    return cq.Solid.extrudeLinear(face, cq.Vector(0.0, 0.0, float(thickness_mm)))


# --- measurements on the profile -------------------------------------------------------

def chord(face: cq.Face, point, direction) -> tuple[np.ndarray, np.ndarray]:
    """End points (mm) of the piece of the line through ``point`` along ``direction`` that
    lies in the face and contains ``point``. Raises GeometryError if ``point`` is outside."""
    p = np.asarray(point, dtype=float)
    u = np.asarray(direction, dtype=float)
    u = u / np.linalg.norm(u)
    a, b = p - _PROBE_MM * u, p + _PROBE_MM * u
    probe = cq.Edge.makeLine(cq.Vector(*a, 0.0), cq.Vector(*b, 0.0))
    common = cq.Shape.cast(BRepAlgoAPI_Common(face.wrapped, probe.wrapped).Shape())
    for edge in common.Edges():
        s = np.array(edge.startPoint().toTuple()[:2])
        e = np.array(edge.endPoint().toTuple()[:2])
        ts, te = sorted((np.dot(s - p, u), np.dot(e - p, u)))
        if ts <= 1e-9 and te >= -1e-9:
            return p + ts * u, p + te * u
    raise GeometryError(f"point ({p[0]:.3f}, {p[1]:.3f}) mm is not inside the profile")


def chord_length_mm(face: cq.Face, point, direction) -> float:
    """Length (mm) of :func:`chord`."""
    s, e = chord(face, point, direction)
    return float(np.linalg.norm(e - s))


def hinge_neck_mm(face: cq.Face, hinge: Part) -> float:
    """In-plane thickness (mm) of a hinge neck measured on the profile: the chord across the
    hinge's axis at mid-length."""
    a, b = hinge.axis
    u = (b - a) / np.linalg.norm(b - a)
    return chord_length_mm(face, (a + b) / 2, (-u[1], u[0]))


def link_direction(face: cq.Face, link: Part) -> np.ndarray:
    """Unit direction of a link's centre line measured on the profile.

    The link is cut along x (or along y for a link nearer the horizontal) at 1/3 and 2/3 of
    its length; the chord mid-points lie on the centre line whatever its angle, so their
    difference gives the direction without assuming it.
    """
    a, b = link.axis
    cut = (1.0, 0.0) if abs(b[1] - a[1]) >= abs(b[0] - a[0]) else (0.0, 1.0)
    mids = [np.mean(chord(face, a + f * (b - a), cut), axis=0) for f in (1 / 3, 2 / 3)]
    v = mids[1] - mids[0]
    return v / np.linalg.norm(v)


def lean_from_vertical_deg(v: np.ndarray) -> float:
    """Angle (deg) between a direction and the vertical (phi1 for a side link)."""
    return math.degrees(math.atan2(abs(v[0]), abs(v[1])))


def rise_above_horizontal_deg(v: np.ndarray) -> float:
    """Angle (deg) between a direction and the horizontal (phi2 for a middle link)."""
    return math.degrees(math.atan2(abs(v[1]), abs(v[0])))


# --- boundary loops as lines and arcs --------------------------------------------------

def _signed_area(xy: np.ndarray) -> float:
    x, y = xy[:, 0], xy[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def _bulge(s: np.ndarray, m: np.ndarray, e: np.ndarray) -> float:
    """DXF bulge tan(theta/4) of the circular arc from s through m to e (positive = CCW)."""
    v1, v2 = s - m, e - m
    inscribed = math.atan2(abs(v1[0] * v2[1] - v1[1] * v2[0]), float(np.dot(v1, v2)))
    turn = (m - s)[0] * (e - m)[1] - (m - s)[1] * (e - m)[0]
    return math.copysign(math.tan((math.pi - inscribed) / 2.0), turn)


def wire_loop(wire: cq.Wire, ccw: bool) -> np.ndarray:
    """One closed boundary as an (n, 3) array of vertices ``x, y, bulge`` (mm): the edge from
    vertex i to i + 1 (cyclically) is a line (bulge 0) or a circular arc (DXF bulge).

    Edges are chained end to start, so the loop is ordered whatever the edges' own
    orientation; ``ccw`` chooses the winding. Raises GeometryError for other edge types.
    """
    segs = []
    for edge in wire.Edges():
        kind = edge.geomType()
        s, e = (np.array(p.toTuple()[:2]) for p in (edge.startPoint(), edge.endPoint()))
        if kind == "LINE":
            segs.append((s, e, None))
        elif kind == "CIRCLE":
            segs.append((s, e, np.array(edge.positionAt(0.5).toTuple()[:2])))
        else:
            raise GeometryError(f"profile edge of type {kind}: only lines and arcs can be cut")
    tol = 1e-6
    chain = [segs.pop(0)]
    while segs:
        end = chain[-1][1]
        for i, (s, e, m) in enumerate(segs):
            if np.linalg.norm(s - end) < tol:
                chain.append(segs.pop(i))
                break
            if np.linalg.norm(e - end) < tol:
                segs.pop(i)
                chain.append((e, s, m))
                break
        else:
            raise GeometryError("profile boundary is not a closed chain of edges")
    if np.linalg.norm(chain[-1][1] - chain[0][0]) > tol:
        raise GeometryError("profile boundary does not close")
    if len(chain) == 1 and chain[0][2] is not None:  # a full circle: split it into two arcs
        s, _, m = chain[0]
        centre = wire.Center().toTuple()[:2]
        opposite = 2 * np.asarray(centre) - s
        chain = [(s, opposite, m), (opposite, s, 2 * np.asarray(centre) - m)]
    loop = np.array([[*s, 0.0 if m is None else _bulge(s, m, e)] for s, e, m in chain])
    if (_signed_area(loop[:, :2]) > 0) != ccw:
        # reverse: vertex order flips, and each bulge moves to the other end and changes sign
        loop = np.column_stack([loop[::-1, :2], -np.roll(loop[::-1, 2], -1)])
    return loop


def face_loops(face: cq.Face) -> tuple[np.ndarray, list[np.ndarray]]:
    """The outline (counter-clockwise) and the holes (clockwise) of a face, as
    :func:`wire_loop` arrays."""
    return wire_loop(face.outerWire(), ccw=True), [wire_loop(w, ccw=False) for w in face.innerWires()]


def flatten_loop(loop: np.ndarray, max_step_deg: float = 5.0) -> np.ndarray:
    """Points (m, 2) along a ``x, y, bulge`` loop, arcs sampled every ``max_step_deg`` or
    finer (for drawing)."""
    pts = []
    n = len(loop)
    for i in range(n):
        s, e, b = loop[i, :2], loop[(i + 1) % n, :2], loop[i, 2]
        pts.append(s)
        if b == 0.0:
            continue
        theta = 4.0 * math.atan(b)                  # signed included angle
        c = np.linalg.norm(e - s)
        r = c / (2.0 * math.sin(abs(theta) / 2.0))
        mid = (s + e) / 2
        normal = np.array([-(e - s)[1], (e - s)[0]]) / c  # left of the chord
        centre = mid + normal * math.copysign(r * math.cos(theta / 2.0), b)
        a0 = math.atan2(*(s - centre)[::-1])
        steps = max(2, math.ceil(abs(math.degrees(theta)) / max_step_deg))
        for k in range(1, steps):
            a = a0 + theta * k / steps
            pts.append(centre + r * np.array([math.cos(a), math.sin(a)]))
    return np.array(pts)
