"""The reconstructed DACM geometry (DESIGN section 3): key points and the parts of the profile.

Coordinates in mm: x across the width, y up, origin at the bottom centre of the footprint.
The beam model (:mod:`geometry.topology`), the feasibility rules (:mod:`geometry.checks`)
and the CAD profile (:mod:`geometry.cad`) are all drawn from this one layout, so they agree.

Left side chain, bottom to top: base hinge (1) at P0 on the base plate, lower link, knee
hinge (2) at P1 under the knee block, knee block, knee hinge (3) at P2 on top of it, upper
link, top hinge (4) at P3 under the top plate. The right chain mirrors it (hinges 8, 7, 6,
5). The middle branch runs from the knee block's inner face K, rising at phi2, to the
platform's side face Q (hinges 9 and 10 on the left, 12 and 11 on the right).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from geometry.params import Design


@dataclass(frozen=True)
class Part:
    """One piece of the profile: a convex polygon (counter-clockwise, mm).

    ``kind`` is "plate", "block", "platform", "post", "link" or "hinge"; ``hinge`` is the
    thesis hinge number (0 if not a hinge); ``axis`` is the centre line (2, 2) of a part that
    bends (a link, a hinge, a half of a plate, of the platform or of a knee block), and
    ``width`` its in-plane thickness; ``body`` names the body a half belongs to (the part's
    own name if it is whole).
    """

    name: str
    kind: str
    polygon: np.ndarray
    hinge: int = 0
    axis: np.ndarray | None = None
    width: float = 0.0
    body: str = ""

    def __post_init__(self):
        if not self.body:
            object.__setattr__(self, "body", self.name)


@dataclass(frozen=True)
class Layout:
    """Key points (left side; the right side mirrors x) and the derived levels, mm."""

    design: Design
    y_base: float        # top face of the base plate
    y_top: float         # bottom face of the top plate
    P0: np.ndarray       # base hinge root on the base plate (left)
    P1: np.ndarray       # knee hinge root under the knee block
    P2: np.ndarray       # knee hinge root on top of the knee block
    P3: np.ndarray       # top hinge root under the top plate
    K: np.ndarray        # middle link root on the knee block's inner face
    Q: np.ndarray        # middle link root on the platform's side face
    input_point: np.ndarray   # top plate centre, top face (load applied here, downward)
    output_point: np.ndarray  # the mirror: platform underside centre (top plate's for basis)
    post_top: float      # fiber tip level (top of the fiber post)

    @property
    def knee_centre(self) -> np.ndarray:
        """The left knee block's centre, where its two halves (and the beam model's two
        stubs) meet and the middle link's root joins it (mm)."""
        return (self.P1 + self.P2) / 2

    @functools.cached_property
    def side_members(self) -> tuple[SideMember, ...]:
        """The hinge-link-hinge members, in the order and with the hinge numbers of the loop
        numbering of :mod:`geometry.params` (built once: the profile, the beam model and the
        feasibility rules all read them)."""
        d = self.design
        upward, sideways = (0.0, 1.0), (1.0, 0.0)     # the normals of horizontal and vertical faces
        base = Face("base plate", upward, -math.inf, math.inf, d.plate_thickness_mm)
        top = Face("top plate", upward, -math.inf, math.inf, d.plate_thickness_mm)
        # a knee's bottom and top faces
        knee_l = Face("left knee", upward, -d.width_mm / 2, d.knee_width_mm, d.knee_height_mm)
        knee_r = Face("right knee", upward, d.width_mm / 2 - d.knee_width_mm, d.knee_width_mm, d.knee_height_mm)
        P0, P1, P2, P3 = self.P0, self.P1, self.P2, self.P3
        m = [SideMember("left lower", np.array([P0, P1]), (1, 2), (base, knee_l), d.phi1_deg),
             SideMember("left upper", np.array([P2, P3]), (3, 4), (knee_l, top), d.phi1_deg),
             SideMember("right upper", np.array([_mirror(P3), _mirror(P2)]), (5, 6), (top, knee_r), d.phi1_deg),
             SideMember("right lower", np.array([_mirror(P1), _mirror(P0)]), (7, 8), (knee_r, base), d.phi1_deg)]
        if not d.is_basis:
            # a knee's inner face, and the platform's side face
            y_knee, y_platform = float(P1[1]), float(self.output_point[1])
            inner_l = Face("left knee", sideways, y_knee, d.knee_height_mm, d.knee_width_mm)
            inner_r = inner_l._replace(body="right knee")
            platform = Face("platform", sideways, y_platform, d.platform_thickness_mm, d.platform_width_mm / 2)
            m += [SideMember("left middle", np.array([self.K, self.Q]), (9, 10), (inner_l, platform), d.phi2_deg),
                  SideMember("right middle", np.array([_mirror(self.Q), _mirror(self.K)]), (11, 12),
                             (platform, inner_r), d.phi2_deg)]
        return tuple(m)


def _mirror(p: np.ndarray) -> np.ndarray:
    return p * np.array([-1.0, 1.0])


def make_layout(d: Design) -> Layout:
    """Key points of a design. Pure arithmetic; no feasibility check (see geometry.checks)."""
    W, H = d.width_mm, d.height_mm
    y_base = d.plate_thickness_mm
    y_top = H - d.plate_thickness_mm
    rise = (y_top - y_base - d.knee_height_mm) / 2.0  # vertical rise of each side member
    x_knee = -W / 2 + d.knee_width_mm / 2
    x_root = x_knee + rise * math.tan(math.radians(d.phi1_deg))
    P0 = np.array([x_root, y_base])
    P1 = np.array([x_knee, y_base + rise])
    P2 = np.array([x_knee, y_base + rise + d.knee_height_mm])
    P3 = np.array([x_root, y_top])
    y_mid = (P1[1] + P2[1]) / 2
    K = np.array([-W / 2 + d.knee_width_mm, y_mid])
    if d.is_basis:
        Q = K.copy()
        output = np.array([0.0, y_top])
    else:
        span = -d.platform_width_mm / 2 - K[0]
        Q = np.array([-d.platform_width_mm / 2, y_mid + span * math.tan(math.radians(d.phi2_deg))])
        output = np.array([0.0, Q[1] - d.platform_thickness_mm / 2])
    return Layout(d, y_base, y_top, P0, P1, P2, P3, K, Q, np.array([0.0, H]), output,
                  output[1] - d.fiber_clearance_mm)


def _rect(x0: float, y0: float, x1: float, y1: float) -> np.ndarray:
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=float)


def bar(a: np.ndarray, b: np.ndarray, width: float) -> np.ndarray:
    """Rectangle of ``width`` around segment a-b."""
    # Python-float arithmetic: a profile has about 30 bars and a sweep checks thousands of profiles
    (a0, a1), (b0, b1) = (float(a[0]), float(a[1])), (float(b[0]), float(b[1]))
    dx, dy = b0 - a0, b1 - a1
    length = math.hypot(dx, dy)
    ux, uy = dx / length, dy / length
    nx, ny = -uy * width / 2, ux * width / 2
    return np.array([[a0 - nx, a1 - ny], [b0 - nx, b1 - ny], [b0 + nx, b1 + ny], [a0 + nx, a1 + ny]])


def member_chain(a: np.ndarray, b: np.ndarray, hinge_length: float) -> np.ndarray:
    """Nodes of a hinge-link-hinge member from a to b: (4, 2) = a, a + l_h u, b - l_h u, b."""
    (a0, a1), (b0, b1) = (float(a[0]), float(a[1])), (float(b[0]), float(b[1]))
    length = math.hypot(b0 - a0, b1 - a1)
    ux, uy = (b0 - a0) / length, (b1 - a1) / length
    return np.array([(a0, a1), (a0 + ux * hinge_length, a1 + uy * hinge_length),
                     (b0 - ux * hinge_length, b1 - uy * hinge_length), (b0, b1)])


class Face(NamedTuple):
    """The face of a body that a hinge joins (mm): the body's name; the face's normal, a
    positive unit axis (y for the plates' and knees' horizontal faces, x for the knees' and
    the platform's vertical side faces); where the face starts along the other axis and its
    length there (``across``: infinite for the plates, taken as long: a top-plate half runs
    link_width_mm past its hinge); and the body's depth behind it."""

    body: str
    normal: tuple[float, float]
    start: float
    across: float
    depth: float


class SideMember(NamedTuple):
    """A hinge-link-hinge member: its name, end points (2, 2) on the faces of the bodies it
    joins, its hinge numbers, the faces (one per end) and its lean from their normals, deg
    (phi1 for the side links, whose faces are the plates' and knees' horizontal ones; phi2
    for the middle links, on the knees' and platform's vertical side faces)."""

    name: str
    ends: np.ndarray
    hinges: tuple[int, int]
    faces: tuple[Face, Face]
    lean_deg: float


def make_parts(lay: Layout) -> list[Part]:
    """The convex pieces whose union is the 2D profile."""
    d = lay.design
    W, H = d.width_mm, d.height_mm
    top_half = -lay.P3[0] + d.link_width_mm
    yc = lay.y_top + d.plate_thickness_mm / 2  # the top plate's centre line
    parts = [
        Part("base plate", "plate", _rect(-W / 2, 0.0, W / 2, lay.y_base)),
        # the top plate bends (it spans the top hinges): two halves, each along its centre
        # line from the middle to a top hinge, like the beam model's two plate members
        Part("top plate left", "plate", _rect(-top_half, lay.y_top, 0.0, H), 0,
             np.array([[0.0, yc], [lay.P3[0], yc]]), d.plate_thickness_mm),
        Part("top plate right", "plate", _rect(0.0, lay.y_top, top_half, H), 0,
             np.array([[0.0, yc], [-lay.P3[0], yc]]), d.plate_thickness_mm),
        # a knee block bends between its hinges (the beam model's two stubs): two halves, each
        # along its centre line from a face to the block's centre
        *_knee_halves("left knee", -W / 2, lay),
        *_knee_halves("right knee", W / 2 - d.knee_width_mm, lay),
        Part("fiber post", "post", _rect(-d.fiber_post_width_mm / 2, lay.y_base - d.plate_thickness_mm / 2,
                                         d.fiber_post_width_mm / 2, lay.post_top)),
    ]
    if not d.is_basis:
        # the platform bends between the middle hinges (like the top plate): two halves,
        # each along its centre line from the middle to a middle hinge
        y0, half = lay.output_point[1], d.platform_width_mm / 2
        ym = y0 + d.platform_thickness_mm / 2
        parts += [Part("platform left", "platform", _rect(-half, y0, 0.0, y0 + d.platform_thickness_mm), 0,
                       np.array([[0.0, ym], [-half, ym]]), d.platform_thickness_mm),
                  Part("platform right", "platform", _rect(0.0, y0, half, y0 + d.platform_thickness_mm), 0,
                       np.array([[0.0, ym], [half, ym]]), d.platform_thickness_mm)]
    for sm in lay.side_members:
        (h1, h2) = sm.hinges
        parts += _member_parts(sm.name, sm.ends.tobytes(), sm.hinges, sm.faces, d.hinge_length_mm,
                               d.hinge_thickness_mm[h1 - 1], d.hinge_thickness_mm[h2 - 1], d.link_width_mm)
    return parts


@functools.lru_cache(maxsize=1024)
def _member_parts(name: str, ends: bytes, hinges: tuple[int, int], faces: tuple[Face, Face], hinge_length: float,
                  t1: float, t2: float, link_width: float) -> tuple[Part, Part, Part]:
    """A side member's hinge, link and hinge parts (``ends``: its (2, 2) end points' bytes).
    Cached (the cells of a sweep row share their side members, the rows their middle
    members); the arrays are read-only."""
    a, b = np.frombuffer(ends).reshape(2, 2)
    nodes = member_chain(a, b, hinge_length)
    nodes.flags.writeable = False
    (h1, h2), (face1, face2) = hinges, faces
    out = (Part(f"hinge {h1}", "hinge", rooted_neck(nodes[0], nodes[1], t1, face1), h1, nodes[0:2], t1),
           Part(f"{name} link", "link", bar(nodes[1], nodes[2], link_width), 0, nodes[1:3], link_width),
           Part(f"hinge {h2}", "hinge", rooted_neck(nodes[3], nodes[2], t2, face2), h2, nodes[2:4], t2))
    for part in out:
        part.polygon.flags.writeable = False
    return out


def _knee_halves(body: str, x0: float, lay: Layout) -> list[Part]:
    """A knee block from x0 (mm, its left edge) as its lower and upper halves."""
    w = lay.design.knee_width_mm
    xc, (y0, y1), ym = x0 + w / 2, (lay.P1[1], lay.P2[1]), float(lay.knee_centre[1])
    return [Part(f"{body} {half}", "block", _rect(x0, lo, x0 + w, hi), 0, np.array([[xc, lo], [xc, hi]]), w, body)
            for half, lo, hi in (("lower", y0, ym), ("upper", ym, y1))]


#: How deep a hinge's root reaches into the body it joins, past the face, in neck widths.
ROOT_OVERLAP_PER_THICKNESS = 0.25


def rooted_neck(point: np.ndarray, end: np.ndarray, width: float, face: Face) -> np.ndarray:
    """The neck of ``width`` from ``point`` on a body's ``face`` to ``end``, with its root
    inside the body: on the acute side of a leaning neck its edge is carried on to
    ROOT_OVERLAP_PER_THICKNESS x width deep (that closes the notch the lean leaves there),
    but no further along the face than where the face ends (a neck wider than its face
    overhangs it all the same: geometry.checks' ``hinge_on_face`` rule); on the obtuse side
    it stops where it meets the face. So the root reaches no deeper than a quarter width (a
    bar 2 width long came out through the far faces of the 2 mm plates and knees under
    thick hinges). Convex, counter-clockwise, mm."""
    (f0, f1), (e0, e1) = (float(point[0]), float(point[1])), (float(end[0]), float(end[1]))
    length = math.hypot(e0 - f0, e1 - f1)
    wx, wy = (e0 - f0) / length, (e1 - f1) / length             # out of the body, along the neck
    vx, vy = -wy * width / 2, wx * width / 2                     # half the width, to the left
    sign = math.copysign(1.0, face.normal[0] * wx + face.normal[1] * wy)
    mx, my = sign * face.normal[0], sign * face.normal[1]        # the face's outward normal
    tx, ty = face.normal[1], face.normal[0]                      # the axis along the face
    along, lean, depth = wx * mx + wy * my, vx * mx + vy * my, ROOT_OVERLAP_PER_THICKNESS * width
    slide = wx * tx + wy * ty                                    # along the face per unit s
    bounded = face.across < math.inf and slide != 0.0            # a corner can pass the face's end

    def root(side: float) -> list[float]:
        """The root's corner on one side (-1: right, 1: left): its edge carried on to
        `depth` inside the face (acute side, or a square neck) or to the face (obtuse),
        and back to the face's end if it would pass it."""
        at_face = -side * lean / along
        s = (-(depth if side * lean >= 0 else 0.0) - side * lean) / along
        if bounded:
            c = (f0 + s * wx + side * vx) * tx + (f1 + s * wy + side * vy) * ty
            end_s = s + (min(max(c, face.start), face.start + face.across) - c) / slide
            s = min(max(s, end_s), at_face)
        return [f0 + s * wx + side * vx, f1 + s * wy + side * vy]

    return np.array([root(-1.0), [e0 - vx, e1 - vy], [e0 + vx, e1 + vy], root(1.0)])


def kinematic_amplification(phi1_deg: float, phi2_deg: float | None) -> float:
    """A_kin = 1/2 + cot(phi2) / (2 tan(phi1)) for rigid links on ideal pivots (DESIGN
    section 3); 1 for the basis body, whose output is the top plate."""
    if phi2_deg is None:
        return 1.0
    p1, p2 = math.radians(phi1_deg), math.radians(phi2_deg)
    return 0.5 + 1.0 / (math.tan(p2) * 2.0 * math.tan(p1))
