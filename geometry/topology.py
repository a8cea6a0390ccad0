"""The planar beam model of a design (pure numpy, no CadQuery) and its JSON schema.

This is what the chain-algorithm solver consumes (thesis section 6.2.1, Figure 46): nodes,
members (each a compliant hinge, a link, or a rigid connection inside a plate or block), the
clamped support, the input port and the output port.

JSON schema ``dacm-beam-model/2`` (units mm, MPa; ``/1`` is read too: its profile stations
are [s, t])::

    {"schema": "dacm-beam-model/2",
     "units": {"length": "mm", "modulus": "MPa"},
     "material": {"name": str, "E_MPa": float, "nu": float},
     "nodes": [[x, y], ...],
     "members": [{"kind": "hinge"|"link"|"rigid", "start": int, "end": int,
                  "thickness_mm": float, "depth_mm": float, "hinge": int (0 if none),
                  "name": str,
                  "profile": [[s, t, e], ...] (optional), "neck_mm": [s0, s1] (optional),
                  "root_radius_mm": [r_a, r_b] (optional),
                  "fillet_neck_mm": [[a_left, a_right], [b_left, b_right]] (optional),
                  "axial_spread": float (optional)}, ...],
     "supports": [{"node": int, "dofs": ["x", "y", "rz"]}, ...],
     "input": {"node": int, "direction": [dx, dy]},
     "output": {"node": int, "direction": [dx, dy]}}

``thickness_mm`` is the in-plane size (bending about z), ``depth_mm`` the out-of-plane size
(the sheet thickness); ``rigid`` members join nodes of one rigid body and have no
compliance. A member of varying thickness (a hinge with its root fillets) gives
``profile``: its in-plane thickness t (mm) at stations s (mm from its start, increasing,
from 0 to its length), linear between stations, and the offset e (mm) of the section's
centroid to the left of the member's axis (where a leaning face's two fillets differ; a
station [s, t] reads as e = 0); ``thickness_mm`` is then the neck's, the
thinnest, ``neck_mm`` the stations where the neck of that thickness starts and ends, and
``root_radius_mm`` the fillet radius at each end (0: a sharp root), ``fillet_neck_mm`` the
stations where each root fillet meets the neck, at the start and the end, on the left and
the right of the member (a face square to the member: both at the neck's end; a face that
leans from its normal: the fillet in the acute corner reaches further along the neck than
the one in the obtuse corner). ``axial_spread`` (0 if left out) is E b times the axial
compliance the member has beyond its profile's (:func:`axial_spread`). ``direction`` is a
unit vector: the input force acts along it, and the output travel is measured along it.
"""

from __future__ import annotations

import functools
import json
import math
import reprlib
from dataclasses import dataclass, field

import numpy as np

from geometry.errors import GeometryError
from geometry.layout import Layout, make_layout
from geometry.params import MAX_LENGTH_MM, Design
from geometry.validation import Number, is_integer, is_real

SCHEMA = "dacm-beam-model/2"
#: Schemas read: /1 had [s, t] profile stations (no centroid offset), which read as e = 0.
READABLE_SCHEMAS = (SCHEMA, "dacm-beam-model/1")
MEMBER_KINDS = ("hinge", "link", "rigid")
DOF_NAMES = ("x", "y", "rz")

#: The hinge root rule of the part as cut (DESIGN sections 14 and 16): four constants
#: (``ROOT_DEPTH_PER_THICKNESS``, ``ROOT_DEPTH_PER_LEAN``, ``FILLET_SPREAD_SLOPE``,
#: ``ROOT_BODY_DEPTHS``) fitted once, by least squares on k_out in the linear limit,
#: to the continuum FE of cut and drawn profiles that are not held out
#: (tests/mechanics/data/continuum_table.json: kerf 0 to 1.2 mm, hinges 0.25-1.5 mm, faces
#: leaning 0-34 deg; tests/mechanics/test_root_rule.py refits them).
#:
#: A strip built into a wider elastic body is not clamped at the body's face: the material
#: round its root turns and shears with it, a root compliance that scales with the strip's
#: size there. The member reaches ``ROOT_DEPTH_PER_THICKNESS`` x t past each face, and
#: ``ROOT_DEPTH_PER_LEAN`` x t sin(gamma) further where the face leans gamma from the
#: neck's normal (an oblique strip leaves the face over t / cos(gamma) and turns a wedge of
#: the body with it: a plane-stress FE of one hinge between a block and a link,
#: tests/mechanics/hinge_substructure.py, shows the rotational compliance grow with sin(gamma)
#: and t, not with the fillet's width), less in a body that is not much deeper than that
#: (a 2 mm plate or knee block under a 1 mm hinge): ``ROOT_BODY_DEPTHS`` sets where that
#: begins (:func:`root_depth_mm`).
ROOT_DEPTH_PER_THICKNESS = 0.367
ROOT_DEPTH_PER_LEAN = 0.7193
ROOT_BODY_DEPTHS = 0.8167
#: A root fillet widens the neck faster than the bending stress can spread into it (plane
#: sections do not stay plane where the section grows steeply): each side's fillet counts
#: up to ``FILLET_SPREAD_SLOPE`` x the distance from where it meets the neck (a load-spread
#: angle of about 15 deg), the rest of the arc carries little.
FILLET_SPREAD_SLOPE = 0.255
#: A face that leans gamma from the neck's normal meets the neck's two edges at different
#: depths (the acute corner's edge further along it), so the root is stiffer on that side
#: and an axial force there turns the neck: per leaning root, a compliance coupling an
#: axial force to the end rotation of -``ROOT_COUPLING_PER_LEAN`` x sin(gamma) / (E b t)
#: (rad per N; a plane-stress FE of one hinge between a block and a link,
#: tests/mechanics/hinge_substructure.py, measures it 1.6-8 x the fillets' own coupling,
#: and present at a sharp root too). The member carries it as the root's centroid offset
#: towards the acute corner (:func:`hinge_profile`). Least squares on that FE's axial
#: couplings of ten leaning hinges (t 0.3-1.25 mm, gamma 15-32.3 deg, r 0-0.6 mm), not on
#: bodies; the four constants above were refitted with it.
ROOT_COUPLING_PER_LEAN = 1.98
#: Where a neck meets a wider body, its axial force spreads into that body. The root depth
#: above was fitted on bending and does not carry this compliance. The FE of one hinge between
#: a block and a link (tests/mechanics/hinge_substructure.py) has 10-20 % more axial compliance
#: than the member. Under a strip load on an elastic half-plane the surface sinks as
#: (2 / (pi E)) ln(1 / distance) per unit load (plane stress; Johnson, Contact Mechanics,
#: 1985, chapter 2), so a neck of width a on a body D deep adds about (2 / (pi E b)) ln(D / a).
#: The member carries E b x this = (2 / pi) ln(AXIAL_SPREAD_PER_DEPTH x D / (t +
#: AXIAL_SPREAD_PER_FILLET x r)) (:func:`axial_spread`): r the root fillets' radius, which
#: widen the neck where it meets the body, and D how deep the force spreads before a member
#: of the beam model takes it on (the substructure's block is clamped D behind the face; in a
#: body, :func:`_spread_depth`). Least squares on the substructure's axial compliance
#: (D 2-6 mm, t 0.3-1.4 mm, r 0-0.6 mm, faces square and leaning 20 deg, the link 2 mm
#: wide): RMS 1.7 %, at most 3.4 % (tests/mechanics/test_hinge_substructure.py refits it).
AXIAL_SPREAD_PER_DEPTH = 1.669
AXIAL_SPREAD_PER_FILLET = 0.1084
#: The width (mm) of the contact the input is pushed through: the continuum reference's
#: punch (sensor.mechanics.continuum's default). The input force at the top plate's
#: centre (DESIGN section 3) spreads over it, and two things beam theory leaves out happen
#: under it (:func:`contact_compliance`): the plate under a rigid punch bends less than
#: elsewhere (the top plate's members start CONTACT_START_PER_WIDTH x w either side of the
#: centre, carried rigidly to it), and the punch sinks into the plate (a strip load's
#: ln(1 / w), Johnson, Contact Mechanics, 1985, chapter 2). Both from the plane-stress FE
#: of a plate alone under the reference's punch (tests/mechanics/plate_contact_study.py):
#: least squares on 34 cases (half-spans 3-8 mm, plates 1.5-3 mm deep, punches 0.1-1 mm,
#: w / h <= 0.67), -1.0 to +1.9 %, RMS 0.6 %. The rule they replace (members from +-w/4, the moment
#: of an even load past the contact, and no contact compliance) was 0.8-13 % stiffer than that
#: FE, and its stiff plate offset errors elsewhere on the continuum table.
INPUT_CONTACT_MM = 0.5
CONTACT_START_PER_WIDTH = 0.1964
#: E b x the contact's compliance per half the input force is
#: CONTACT_LOG_SLOPE x ln(CONTACT_DEPTH_FACTOR x h / w) (:func:`contact_compliance`)
CONTACT_LOG_SLOPE = 0.9963
CONTACT_DEPTH_FACTOR = 0.5561
#: Stations per root fillet in a hinge's thickness profile (the arc is sampled at these
#: points and taken linear between them: the flexibility integrals of a quarter circle
#: sampled at 8 points are within 0.1 % of the exact arc's).
FILLET_STATIONS = 8


@dataclass(frozen=True, eq=False)
class BeamModel:
    """A planar frame: arrays indexed by node (``nodes``) and by member (the rest)."""

    nodes: np.ndarray                 # (n, 2) mm
    member_nodes: np.ndarray          # (m, 2) int: start, end
    member_kind: tuple[str, ...]      # "hinge" | "link" | "rigid"
    thickness_mm: np.ndarray          # (m,) in-plane thickness
    depth_mm: np.ndarray              # (m,) out-of-plane depth
    hinge_number: np.ndarray          # (m,) thesis hinge number, 0 if not a hinge
    member_name: tuple[str, ...]
    supports: tuple[tuple[int, tuple[str, ...]], ...]   # (node, fixed dofs)
    input_node: int
    input_direction: np.ndarray       # (2,) unit vector of the input force
    output_node: int
    output_direction: np.ndarray      # (2,) unit vector of the measured output travel
    E_MPa: float
    nu: float
    material_name: str = "custom"
    labels: dict = field(default_factory=dict)  # optional named nodes, for reports
    profile_mm: tuple = ()            # per member: None (uniform) or (k, 3) stations s, t, e
    neck_mm: np.ndarray | None = None  # (m, 2) stations where the neck starts and ends
    root_radius_mm: np.ndarray | None = None  # (m, 2) fillet radius at each end (0: sharp)
    fillet_neck_mm: np.ndarray | None = None  # (m, 2, 2) where each fillet meets the neck, [start, end] x [left, right]
    axial_spread: np.ndarray | None = None  # (m,) E b x the axial compliance beyond the profile's (axial_spread)

    def __post_init__(self):
        m = len(self.member_kind)
        if not self.profile_mm:
            object.__setattr__(self, "profile_mm", (None,) * m)
        if self.neck_mm is None:
            object.__setattr__(self, "neck_mm", np.column_stack([np.zeros(m), self.lengths_mm]))
        if self.root_radius_mm is None:
            object.__setattr__(self, "root_radius_mm", np.zeros((m, 2)))
        if self.fillet_neck_mm is None:
            object.__setattr__(self, "fillet_neck_mm", np.repeat(self.neck_mm[:, :, None], 2, axis=2))
        if self.axial_spread is None:
            object.__setattr__(self, "axial_spread", np.zeros(m))

    @property
    def lengths_mm(self) -> np.ndarray:
        a, b = self.nodes[self.member_nodes[:, 0]], self.nodes[self.member_nodes[:, 1]]
        return np.linalg.norm(b - a, axis=1)

    @property
    def hinge_members(self) -> np.ndarray:
        """Member indices of the hinges, ordered by thesis hinge number."""
        idx = np.flatnonzero(self.hinge_number > 0)
        return idx[np.argsort(self.hinge_number[idx])]


def _key(p) -> tuple[float, float]:
    """A point as a dict key, rounded to 1e-12 mm (so that equal points computed two ways
    meet)."""
    return round(float(p[0]), 12), round(float(p[1]), 12)


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def root_depth_mm(t_mm: float, gamma_deg: float = 0.0, body_mm: float = math.inf) -> float:
    """How far past a face (mm) a hinge of neck thickness t (mm), leaving a face whose normal
    leans ``gamma_deg`` (deg, either way: its sign does not count) from its axis, is
    effectively clamped in a body ``body_mm`` deep (see
    :data:`ROOT_DEPTH_PER_THICKNESS`): the half-space depth
    D0 = t (ROOT_DEPTH_PER_THICKNESS + ROOT_DEPTH_PER_LEAN sin gamma), less in a body not
    much deeper than it, D0 / (1 + D0 / (ROOT_BODY_DEPTHS x body))."""
    d0 = t_mm * (ROOT_DEPTH_PER_THICKNESS + ROOT_DEPTH_PER_LEAN * math.sin(math.radians(abs(gamma_deg))))
    return d0 / (1.0 + d0 / (ROOT_BODY_DEPTHS * body_mm))


def axial_spread(t_mm: float, radius_mm: float, body_mm: float) -> float:
    """E b times the axial compliance (dimensionless) that a hinge's neck of thickness t (mm),
    rooted with fillets of radius r (mm) in a body ``body_mm`` deep behind its face, has beyond
    its thickness profile's: the stress spreading from the neck into the body (see
    :data:`AXIAL_SPREAD_PER_DEPTH`), (2 / pi) ln(AXIAL_SPREAD_PER_DEPTH x D / (t +
    AXIAL_SPREAD_PER_FILLET x r)), and never below 0."""
    ratio = AXIAL_SPREAD_PER_DEPTH * body_mm / (t_mm + AXIAL_SPREAD_PER_FILLET * radius_mm)
    return max(2.0 / math.pi * math.log(ratio), 0.0)


def input_contact_mm(design: Design) -> float:
    """The input's contact width (mm) the beam model and the continuum reference take by
    default: the reference's punch, :data:`INPUT_CONTACT_MM`, or half the top plate's
    thickness on a plate thinner than twice that (the contact rule's fitted range,
    :func:`contact_compliance`)."""
    return min(INPUT_CONTACT_MM, contact_rule(design).hi)


def contact_rule(design: Design) -> Number:
    """The rule of the input's contact width (mm): positive, at most half the top plate's
    thickness, the range :func:`contact_compliance` is fitted on (the beam model's
    ``contact_mm``, the continuum reference's punch)."""
    return Number(0.0, design.plate_thickness_mm / 2, lo_open=True, unit="mm, at most half the top plate's thickness")


def contact_compliance(contact_mm: float, plate_mm: float) -> float:
    """E b times the compliance (dimensionless) of the input's contact, w = ``contact_mm``
    wide, on a plate ``plate_mm`` deep, per the whole input force: from the punch to the
    plate's centre line, beyond the plate's bending (see :data:`INPUT_CONTACT_MM`),
    (CONTACT_LOG_SLOPE / 2) ln(CONTACT_DEPTH_FACTOR x h / w); the rule is fitted for
    w <= h / 2, where it is positive."""
    return CONTACT_LOG_SLOPE / 2 * math.log(CONTACT_DEPTH_FACTOR * plate_mm / contact_mm)


def _fillet_sides(t_mm: float, radius_mm: float, shoulder_mm: float, gamma_deg: float,
                  body_mm: float = math.inf) -> list[tuple]:
    """The root fillets on the two sides of a neck meeting a face (mm, stations along the
    neck measured from where its axis crosses the face).

    The face's normal leans ``gamma_deg`` from the neck's axis, so the two re-entrant
    corners are 90 - gamma (acute, at +t/2 tan gamma) and 90 + gamma (obtuse, at
    -t/2 tan gamma). A fillet of radius r in a corner of angle theta is tangent to the neck
    r / tan(theta / 2) from the corner. A face that steps out by less than r beside the
    neck (``shoulder_mm``, square faces only) ends the arc on the shoulder's corner.
    Returns per side (f, n, r): the arc r - sqrt(r^2 - (n - s)^2) fills the side from the
    station f where it leaves the face to the station n where it meets the neck.
    """
    g = math.radians(gamma_deg)
    shoulder_mm = max(shoulder_mm, 0.0)  # a face narrower than the neck leaves no re-entrant corner
    sides = []
    for theta, corner in ((math.pi / 2 - g, t_mm / 2 * math.tan(g)), (math.pi / 2 + g, -t_mm / 2 * math.tan(g))):
        if radius_mm <= 0:
            sides.append((corner, corner, 0.0))
            continue
        if gamma_deg != 0 and shoulder_mm < radius_mm / math.tan(theta / 2):
            radius = shoulder_mm * math.tan(theta / 2)  # the largest fillet the face holds
            d = radius / math.tan(theta / 2)
            sides.append((corner + d * math.cos(theta), corner + d, radius))
            continue
        if gamma_deg == 0 and shoulder_mm < radius_mm:
            reach = math.sqrt(radius_mm**2 - (radius_mm - shoulder_mm) ** 2)
            sides.append((corner, corner + reach, radius_mm))
            continue
        d = radius_mm / math.tan(theta / 2)
        sides.append((corner + d * math.cos(theta), corner + d, radius_mm))
    return sides


def _fill_mm(s: np.ndarray, side: tuple) -> np.ndarray:
    """One side's fillet height above the neck edge (mm) at stations s (see _fillet_sides)."""
    f, n, r = side
    if r <= 0:
        return np.zeros_like(s)
    gap = np.clip(n - s, 0.0, r)
    return np.minimum(np.where(s < n, r - np.sqrt(r * r - gap * gap), 0.0), FILLET_SPREAD_SLOPE * np.clip(n - s, 0.0, None))


@functools.lru_cache(maxsize=4096)
def hinge_profile(t_mm: float, neck_length_mm: float, ends) -> tuple[np.ndarray, tuple, float, float, tuple]:
    """The thickness profile of a hinge member of the cut part (mm).

    The neck of thickness t and drawn length l_h runs between two faces; at each face the
    cut leaves a fillet of radius r in both re-entrant corners (``ends``: (r, shoulder,
    gamma_deg, body depth) at the start and at the end, see :func:`_fillet_sides` and
    :func:`root_depth_mm`; r = kerf / 2 for a water-jet, 0 for the drawing). The strip
    leaves the face, where the first fillet leaves it, t plus both fillets' heights wide;
    the member reaches :func:`root_depth_mm` further, into the body, at that width, where
    the elastic root is taken as clamped, on the axis. Where a face leans, its two fillets
    differ (the acute corner's reaches further along the neck), so the section's centroid
    leaves the axis by e = (acute - obtuse fillet height) / 2 towards the acute corner: an
    axial force bends the fillets (the member's axial-bending coupling,
    sensor.mechanics.solver.profile_flexibility). The elastic root is clamped on the axis, so
    e runs from 0 there to its value at the face (linear between those two stations), as the
    root rule's constants were fitted with; at a leaning face's root it starts from the
    offset that carries the root's own coupling (:data:`ROOT_COUPLING_PER_LEAN`) instead.

    Cached (a sweep's cells share their hinges); the stations are read-only.
    Returns (stations (k, 3) of s, t and e, (s0, s1) where the uniform neck starts and ends,
    member length, how far behind the start face's axis crossing the member starts, and
    per end the stations where its acute-corner and obtuse-corner fillets meet the neck),
    all in mm from the member's start: ``k`` = 2 + 4 :data:`FILLET_STATIONS` for every
    hinge, so the profiles of a batch stack.
    """
    start = _fillet_sides(t_mm, *ends[0][:3])
    # the end face crosses the axis at l_h; its sides, mirrored, in the member's stations
    end = [(neck_length_mm - f, neck_length_mm - n, r) for f, n, r in _fillet_sides(t_mm, *ends[1][:3])]
    face0, face1 = max(f for f, _, _ in start), min(f for f, _, _ in end)
    neck0, neck1 = max(n for _, n, _ in start), min(n for _, n, _ in end)
    arc = np.linspace(0.0, 1.0, FILLET_STATIONS)
    s = np.concatenate([face0 + (n - face0) * arc for _, n, _ in start]
                       + [face1 - (face1 - n) * arc for _, n, _ in end])
    s = np.sort(np.clip(s, face0, face1))

    def fill_heights(x):  # on each side of the neck, the higher of its two ends' fillets
        return [np.maximum(_fill_mm(x, a), _fill_mm(-x, (-f, -n, r))) for a, (f, n, r) in zip(start, end)]

    # each side pairs the two ends' acute-corner (or obtuse-corner) fillets: a hinge leans at
    # one end only (its link end is square), so the sides are the leaning face's two corners
    if ends[0][2] != 0 and ends[1][2] != 0:
        raise GeometryError(f"hinge profile: both ends lean ({ends[0][2]:g}, {ends[1][2]:g} deg); "
                            "one end must be square")
    acute, obtuse = fill_heights(s)
    t = t_mm + acute + obtuse
    e = (acute - obtuse) / 2  # the section's centroid, off the axis towards the acute corner
    da = root_depth_mm(t_mm, gamma_deg=ends[0][2], body_mm=ends[0][3])
    db = root_depth_mm(t_mm, gamma_deg=ends[1][2], body_mm=ends[1][3])
    st = np.column_stack([np.concatenate([[face0 - da], s, [face1 + db]]),
                          np.concatenate([[t[0]], t, [t[-1]]]),
                          np.concatenate([[0.0], e, [0.0]])])
    # a leaning face's root coupling (ROOT_COUPLING_PER_LEAN): the offset e_r at the elastic
    # root, falling linearly to the face's, adds int e ds / (E I) = e_r d / 2 x 12 / (E b t0^3)
    # over the root depth d at the face's width t0, which is K sin(gamma) / (E b t)
    for row, (_, _, gamma, _), depth in ((0, ends[0], da), (-1, ends[1], db)):
        if gamma != 0 and depth > 0:
            lean = math.sin(math.radians(abs(gamma)))
            st[row, 2] = ROOT_COUPLING_PER_LEAN * lean * st[row, 1] ** 3 / (6 * t_mm * depth)
    shift = da - face0  # the member starts this far behind the start face's axis crossing
    st[:, 0] += shift
    st.flags.writeable = False  # cached: a sweep's cells share their hinges' profiles
    fillets = tuple(tuple(float(n + shift) for _, n, _ in sides) for sides in (start, end))
    return st, (float(neck0 + shift), float(neck1 + shift)), float(st[-1, 0]), float(shift), fillets


def root_radius_mm(design: Design) -> float:
    """The fillet radius (mm) at every hinge root of the part as cut: the jet's radius,
    kerf / 2 (thesis section 6.1.2.1: water-jet cut; DESIGN section 16), or the design's own
    drawn root radius if larger. 0 with ``kerf_mm = 0`` and no drawn radius: the drawing."""
    return max(design.kerf_mm / 2.0, design.root_radius_mm)


def build_beam_model(design: Design, layout: Layout | None = None, input_guided: bool = True,
                     contact_mm: float | None = None) -> BeamModel:
    """The beam model of the part as cut (``design.kerf_mm``; 0: the drawing), hinges
    numbered as in Figure 48 (see geometry.params).

    Each hinge member is the neck with its root fillets (:func:`hinge_profile`), reaching
    its root depth (:func:`root_depth_mm`) into the body it joins and into the link, with
    the axial compliance of the stress spreading into that body (:func:`axial_spread`).
    The input force is spread over a contact ``contact_mm`` wide (mm, at most half the top
    plate's thickness; default :func:`input_contact_mm`, see :data:`INPUT_CONTACT_MM`): a link from the input point to the
    plate's centre line with the contact's axial compliance (:func:`contact_compliance`; its
    thickness the one that gives it), the plate's members starting a little way either side.

    The base plate is clamped. With ``input_guided`` (the default) the input port is guided
    sideways (its x is held), as the thesis' X-stage held it when it pushed the specimens
    (section 6.2.4): without that guide a stiff amplifying body such as sample B can sway
    sideways under its own 1 mm load (a bifurcation the solver reports). Costs a few tens of
    microseconds: sweeps build thousands.
    """
    lay = layout or make_layout(design)
    if contact_mm is None:
        contact_mm = input_contact_mm(design)
    contact_mm = contact_rule(design).check("contact_mm", contact_mm, GeometryError)
    d = design
    # scalar arithmetic on (x, y) tuples: a sweep builds thousands of models, and numpy's
    # per-call cost on 2-vectors is most of the work (same operations, same results)
    nodes: list[tuple[float, float]] = []
    members: list[tuple] = []  # (kind, start, end, thickness, hinge, name)

    def node(p) -> int:
        nodes.append((float(p[0]), float(p[1])))
        return len(nodes) - 1

    def mirrored(p) -> tuple[float, float]:
        return -float(p[0]), float(p[1])

    base_l, base_r = node(lay.P0), node(mirrored(lay.P0))
    knee_lo_l, knee_hi_l = node(lay.P1), node(lay.P2)
    knee_lo_r, knee_hi_r = node(mirrored(lay.P1)), node(mirrored(lay.P2))
    inp = node(lay.input_point)  # first node of the input body: its reference node
    yc = lay.y_top + d.plate_thickness_mm / 2           # the top plate's centre line
    plate_mid = node((0.0, yc))
    # every hinge: its thickness profile between its face on a body and its face on a link
    r = root_radius_mm(d)
    profiles, body_depth = {}, {}  # hinge -> hinge_profile(...), its root depth into the body
    spread = {}                    # hinge -> axial_spread(...)
    for sm in lay.side_members:
        (h1, h2), (face1, face2), lean_deg = sm.hinges, sm.faces, sm.lean_deg
        t1, t2 = d.hinge_thickness_mm[h1 - 1], d.hinge_thickness_mm[h2 - 1]
        # each hinge leans from its body face's normal (geometry.layout.SideMember); a link's
        # own end face is square to it
        ends1 = ((r, (face1.across - t1 / math.cos(math.radians(lean_deg))) / 2, lean_deg, face1.depth),
                 (r, (d.link_width_mm - t1) / 2, 0.0, d.link_width_mm))
        ends2 = ((r, (d.link_width_mm - t2) / 2, 0.0, d.link_width_mm),
                 (r, (face2.across - t2 / math.cos(math.radians(lean_deg))) / 2, lean_deg, face2.depth))
        profiles[h1] = p1 = hinge_profile(t1, d.hinge_length_mm, ends1)
        profiles[h2] = p2 = hinge_profile(t2, d.hinge_length_mm, ends2)
        body_depth[h1] = p1[3]                                   # the body is at the start of h1
        body_depth[h2] = p2[2] - p2[3] - d.hinge_length_mm       # and at the end of h2
        spread[h1], spread[h2] = axial_spread(t1, r, _spread_depth(face1)), axial_spread(t2, r, _spread_depth(face2))
    # the plate bends up to the top hinges' effective roots, inside it (see the side chains)
    lean = (lay.P3 - lay.P2) / np.linalg.norm(lay.P3 - lay.P2)
    plate_l = node((lay.P3[0] + lean[0] * body_depth[4], yc))
    plate_r = node((-lay.P3[0] - lean[0] * body_depth[5], yc))
    top_l, top_r = node(lay.P3), node(mirrored(lay.P3))
    anchor = {_key(nodes[i]): i for i in (base_l, base_r, knee_lo_l, knee_hi_l, knee_lo_r, knee_hi_r,
                                          top_l, top_r)}

    # the top plate bends between the top hinges: two members along its centre line, with
    # rigid offsets up to the input point and down to the hinge roots on its underside.
    # A knee block carries the side chain's force from its bottom hinge to its top one: two
    # stubs as wide as the block from its faces to its centre, where the middle link's
    # root joins it (a rigid arm); their axial and shear compliance counts next to thick
    # hinges' (the continuum table's thick-hinged basis bodies: k_out 1-3 % softer). Unlike
    # the plates' members, the stubs start at the faces, not at the hinges' effective roots:
    # the 0.05-0.5 mm a hinge's root reaches into the block counts in both, as the root rule
    # was fitted (stubs stopped at the roots, constants refitted: RMS k_out error 1.029
    # against 1.031 %, the same misses within 0.1 point; one-off run)
    knee_c_l = node(lay.knee_centre)
    knee_c_r = node(mirrored(nodes[knee_c_l]))
    # the input's contact (INPUT_CONTACT_MM): a link down to the plate's centre line as
    # compliant axially as the contact (it carries only the input force: the input is guided
    # and the body symmetric), and the plate's members start either side of the centre
    start = CONTACT_START_PER_WIDTH * contact_mm
    contact_l, contact_r = node((-start, yc)), node((start, yc))
    members += [("link", inp, plate_mid, d.plate_thickness_mm / 2 / contact_compliance(contact_mm, d.plate_thickness_mm),
                 0, "input contact"),
                ("rigid", plate_mid, contact_l, d.plate_thickness_mm, 0, "top plate"),
                ("rigid", plate_mid, contact_r, d.plate_thickness_mm, 0, "top plate"),
                ("link", contact_l, plate_l, d.plate_thickness_mm, 0, "top plate left"),
                ("link", contact_r, plate_r, d.plate_thickness_mm, 0, "top plate right"),
                ("rigid", plate_l, top_l, d.plate_thickness_mm, 0, "top plate"),
                ("rigid", plate_r, top_r, d.plate_thickness_mm, 0, "top plate"),
                ("link", knee_lo_l, knee_c_l, d.knee_width_mm, 0, "left knee"),
                ("link", knee_c_l, knee_hi_l, d.knee_width_mm, 0, "left knee"),
                ("link", knee_lo_r, knee_c_r, d.knee_width_mm, 0, "right knee"),
                ("link", knee_c_r, knee_hi_r, d.knee_width_mm, 0, "right knee")]
    if d.is_basis:
        out = node(lay.output_point)
        members.append(("rigid", plate_mid, out, d.plate_thickness_mm, 0, "top plate"))
    else:
        k_l, k_r = node(lay.K), node(mirrored(lay.K))
        q_l, q_r = node(lay.Q), node(mirrored(lay.Q))
        out = node(lay.output_point)
        anchor.update({_key(nodes[i]): i for i in (k_l, k_r, q_l, q_r)})
        # the platform bends between the middle hinges like the top plate between the top
        # ones: two members along its centre line up to the hinges' effective roots inside it
        rise = math.cos(math.radians(d.phi2_deg))
        mid = node((0.0, float(lay.Q[1])))
        plat_l = node((float(lay.Q[0]) + rise * body_depth[10], float(lay.Q[1])))
        plat_r = node((-float(lay.Q[0]) - rise * body_depth[11], float(lay.Q[1])))
        members += [("rigid", knee_c_l, k_l, d.knee_width_mm, 0, "left knee"),
                    ("rigid", knee_c_r, k_r, d.knee_width_mm, 0, "right knee"),
                    ("rigid", mid, out, d.platform_thickness_mm, 0, "platform"),
                    ("link", mid, plat_l, d.platform_thickness_mm, 0, "platform left"),
                    ("link", mid, plat_r, d.platform_thickness_mm, 0, "platform right"),
                    ("rigid", plat_l, q_l, d.platform_thickness_mm, 0, "platform"),
                    ("rigid", plat_r, q_r, d.platform_thickness_mm, 0, "platform")]

    lh = d.hinge_length_mm
    shape: dict[int, tuple] = {}  # member index -> (profile, neck stations, root radii, fillet stations, spread)
    for sm in lay.side_members:
        (h1, h2), (a, b), name = sm.hinges, sm.ends, sm.name
        t1, t2 = d.hinge_thickness_mm[h1 - 1], d.hinge_thickness_mm[h2 - 1]
        (ax, ay), (bx, by) = a.tolist(), b.tolist()
        length = math.hypot(bx - ax, by - ay)
        ux, uy = (bx - ax) / length, (by - ay) / length
        ia = anchor[_key(a)]
        ib = anchor[_key(b)]
        # elastic roots: each hinge member starts its root depth inside the body and ends its
        # root depth inside the link (rigid offsets carry the bodies out to those points); the
        # link's hinge ends are a + l_h u and b - l_h u (member_chain)
        (p1, neck1, len1, _, fil1), (p2, neck2, len2, _, fil2) = profiles[h1], profiles[h2]
        in1, in2 = body_depth[h1], body_depth[h2]        # root depths into the bodies
        out1, out2 = len1 - lh - in1, len2 - lh - in2    # and into the link
        ra, rb = node((ax - ux * in1, ay - uy * in1)), node((bx + ux * in2, by + uy * in2))
        j1 = node(((ax + ux * lh) + ux * out1, (ay + uy * lh) + uy * out1))
        j2 = node(((bx - ux * lh) - ux * out2, (by - uy * lh) - uy * out2))
        # each fillet's station, left and right: where a hinge meets a body, the face leans
        # from the link's normal (the plates' and knees' faces are horizontal, the knees' and
        # the platform's side faces, which the middle links join, vertical); c is the sine
        # of that lean, signed by the side of the member (left: +) the start body's outward
        # face normal tilts towards: the acute corner is on the other side there (and, the
        # end body's normal pointing back along the member, on that side at the end)
        nx, ny = sm.faces[0].normal
        c = -math.copysign(1.0, nx * ux + ny * uy) * (nx * uy - ny * ux)
        # (the link ends are square: both fillets at the neck's end)
        shape[len(members) + 1] = (_centroid_left(p1, c < 0), neck1, (r, r), (_left_right(fil1[0], c < 0), fil1[1]),
                                   spread[h1])
        shape[len(members) + 3] = (_centroid_left(p2, c > 0), neck2, (r, r), (fil2[0], _left_right(fil2[1], c > 0)),
                                   spread[h2])
        members += [("rigid", ia, ra, t1, 0, f"hinge {h1} root"),
                    ("hinge", ra, j1, t1, h1, f"hinge {h1}"),
                    ("link", j1, j2, d.link_width_mm, 0, f"{name} link"),
                    ("hinge", j2, rb, t2, h2, f"hinge {h2}"),
                    ("rigid", ib, rb, t2, 0, f"hinge {h2} root")]

    kinds, starts, ends, thick, hinge, names = zip(*members)
    m = len(members)
    nodes_arr = np.array(nodes)
    lengths = np.linalg.norm(nodes_arr[list(ends)] - nodes_arr[list(starts)], axis=1)
    neck = np.column_stack([np.zeros(m), lengths])
    radius = np.zeros((m, 2))
    fillet = np.repeat(neck[:, :, None], 2, axis=2)
    axial = np.zeros(m)
    for i, (_, span, radii, sides, spreading) in shape.items():
        neck[i], radius[i], fillet[i], axial[i] = span, radii, sides, spreading
    return BeamModel(
        nodes=nodes_arr,
        member_nodes=np.column_stack([starts, ends]).astype(int),
        member_kind=tuple(kinds),
        thickness_mm=np.array(thick, dtype=float),
        depth_mm=np.full(m, d.sheet_thickness_mm),
        hinge_number=np.array(hinge, dtype=int),
        member_name=tuple(names),
        supports=((base_l, DOF_NAMES), (base_r, DOF_NAMES)) + (((inp, ("x", "rz")),) if input_guided else ()),
        input_node=inp,
        input_direction=np.array([0.0, -1.0]),
        output_node=out,
        output_direction=np.array([0.0, -1.0]),
        E_MPa=d.material.E_MPa,
        nu=d.material.nu,
        material_name=d.material.name,
        labels={"input": inp, "output": out, "base left": base_l, "base right": base_r},
        profile_mm=tuple(shape[i][0] if i in shape else None for i in range(m)),
        neck_mm=neck,
        root_radius_mm=radius,
        fillet_neck_mm=fillet,
        axial_spread=axial,
    )


def _spread_depth(face) -> float:
    """How deep (mm) a hinge's axial force spreads into the body behind ``face`` before the
    beam model takes it on (:func:`axial_spread`): to the centre line of a plate, a knee
    block or the platform, whose members run there (half the body's depth behind the face),
    and through the whole base plate, which the continuum clamps along its bottom edge.
    (On the continuum table, the whole depth everywhere left 9 entries outside the targets
    against 3 with this rule, before the root rule was refitted; one-off runs.)"""
    return face.depth if face.body == "base plate" else face.depth / 2


def _centroid_left(stations: np.ndarray, acute_left: bool) -> np.ndarray:
    """A hinge profile's stations with the centroid's offset e signed to the member's left
    (hinge_profile gives it towards the acute corner)."""
    if acute_left:
        return stations
    out = stations.copy()
    out[:, 2] = 0.0 - stations[:, 2]  # 0.0 - x: no -0.0 (profiles are cached by their bytes)
    out.flags.writeable = False
    return out


def _left_right(acute_obtuse: tuple, acute_left: bool) -> tuple:
    """An end's (acute-corner, obtuse-corner) pair as (left, right) of the member."""
    return acute_obtuse if acute_left else acute_obtuse[::-1]


# --- JSON ------------------------------------------------------------------------------

def model_to_dict(model: BeamModel) -> dict:
    """The beam model as a dict of schema ``dacm-beam-model/2``."""
    return {
        "schema": SCHEMA,
        "units": {"length": "mm", "modulus": "MPa"},
        "material": {"name": model.material_name, "E_MPa": model.E_MPa, "nu": model.nu},
        "nodes": model.nodes.tolist(),
        "members": [_member_to_dict(model, i) for i in range(len(model.member_kind))],
        "supports": [{"node": int(n), "dofs": list(dofs)} for n, dofs in model.supports],
        "input": {"node": model.input_node, "direction": model.input_direction.tolist()},
        "output": {"node": model.output_node, "direction": model.output_direction.tolist()},
    }


def _member_to_dict(model: BeamModel, i: int) -> dict:
    s, e = model.member_nodes[i]
    out = {"kind": model.member_kind[i], "start": int(s), "end": int(e),
           "thickness_mm": float(model.thickness_mm[i]), "depth_mm": float(model.depth_mm[i]),
           "hinge": int(model.hinge_number[i]), "name": model.member_name[i]}
    if model.profile_mm[i] is not None:
        out["profile"] = model.profile_mm[i].tolist()
        out["neck_mm"] = model.neck_mm[i].tolist()
        out["root_radius_mm"] = model.root_radius_mm[i].tolist()
        out["fillet_neck_mm"] = model.fillet_neck_mm[i].tolist()
    if model.axial_spread[i]:
        out["axial_spread"] = float(model.axial_spread[i])
    return out


_MODEL_KEYS = {"schema", "units", "material", "nodes", "members", "supports", "input", "output"}
_MEMBER_KEYS = {"kind", "start", "end", "thickness_mm", "depth_mm", "hinge", "name", "profile", "neck_mm",
                "root_radius_mm", "fillet_neck_mm", "axial_spread"}
#: Largest number of stations in a member's thickness profile.
MAX_PROFILE_STATIONS = 1000
_COORD = Number(-MAX_LENGTH_MM, MAX_LENGTH_MM, unit="mm")
_SIZE = Number(0.0, MAX_LENGTH_MM, lo_open=True, unit="mm")
#: Largest model accepted (nodes or members): the designs have a few dozen.
MAX_MODEL_ITEMS = 10_000


def model_from_dict(data: dict, source: str = "beam model") -> BeamModel:
    """Read a beam model from a schema ``dacm-beam-model/2`` (or ``/1``) dict, checking every field:
    types, finiteness, ranges, node indices (integers, not truncated), no unknown keys.
    Raises :class:`GeometryError` naming the field, the value and the rule."""
    def fail(msg):
        raise GeometryError(f"{source}: {msg}")

    def table(value, name, keys, required):
        if not isinstance(value, dict):
            fail(f"{name} = {reprlib.repr(value)}: must be a JSON object")
        unknown = sorted(set(value) - keys)
        if unknown:
            fail(f"{name}: unknown key(s) {', '.join(map(str, unknown))}; known: {', '.join(sorted(keys))}")
        missing = [k for k in required if k not in value]
        if missing:
            fail(f"{name}: missing {missing[0]!r}")
        return value

    def items(value, name):
        if isinstance(value, list) and not value and name == "supports":
            fail("no support: the model would move as a rigid body")
        if not isinstance(value, list) or not 0 < len(value) <= MAX_MODEL_ITEMS:
            fail(f"{name} = {reprlib.repr(value)}: must be a non-empty list of at most {MAX_MODEL_ITEMS} entries")
        return value

    def number(value, name, rule):
        if not rule.ok(value):
            fail(f"{name} = {reprlib.repr(value)}: must be {rule.rule}")
        return float(value)

    def index(value, name, n):
        if not (is_integer(value) and 0 <= value < n):
            fail(f"{name} = {value!r}: must be an integer node index in [0, {n})")
        return int(value)

    def direction(value, name):
        if not (isinstance(value, list) and len(value) == 2 and all(is_real(v) for v in value)
                and 1e-9 < math.hypot(*value) < math.inf):
            fail(f"{name} = {value!r}: must be a non-zero [dx, dy] of finite numbers")
        return _unit(value)

    table(data, "model", _MODEL_KEYS, sorted(_MODEL_KEYS - {"units"}))
    if data["schema"] not in READABLE_SCHEMAS:
        fail(f"schema = {data['schema']!r}: expected one of {', '.join(map(repr, READABLE_SCHEMAS))}")
    mat = table(data["material"], "material", {"name", "E_MPa", "nu"}, ("E_MPa", "nu"))
    E = number(mat["E_MPa"], "material E_MPa", Number(0.0, 1e7, lo_open=True, unit="MPa"))
    nu = number(mat["nu"], "material nu", Number(0.0, 0.5, hi_open=True))
    nodes = []
    for i, p in enumerate(items(data["nodes"], "nodes")):
        if not (isinstance(p, list) and len(p) == 2):
            fail(f"node {i} = {p!r}: must be [x, y] in mm")
        nodes.append([number(v, f"node {i} {c}", _COORD) for v, c in zip(p, "xy")])
    n = len(nodes)
    if n < 2:
        fail(f"nodes: {n} node; a model needs at least 2")
    members = []
    for i, m in enumerate(items(data["members"], "members")):
        table(m, f"member {i}", _MEMBER_KEYS, ("kind", "start", "end"))
        if m["kind"] not in MEMBER_KINDS:
            fail(f"member {i} kind = {m['kind']!r}: must be one of {', '.join(MEMBER_KINDS)}")
        start, end = (index(m[k], f"member {i} {k}", n) for k in ("start", "end"))
        if math.dist(nodes[start], nodes[end]) < 1e-9:
            fail(f"member {i}: start node {start} and end node {end} are at the same point "
                 "(a member needs a length)")
        size = {}
        for k in ("thickness_mm", "depth_mm"):
            if m["kind"] != "rigid" or k in m:
                if k not in m:
                    fail(f"member {i}: missing {k!r} (a {m['kind']} needs it)")
                size[k] = number(m[k], f"member {i} {k}", _SIZE)
        hinge = m.get("hinge", 0)
        if not (is_integer(hinge) and 0 <= hinge <= 99):
            fail(f"member {i} hinge = {hinge!r}: must be an integer hinge number (0 if none)")
        name = m.get("name", f"member {i}")
        if not isinstance(name, str):
            fail(f"member {i} name = {name!r}: must be a string")
        length = math.dist(nodes[start], nodes[end])
        shape = (_member_shape(m, i, length, fail, number) if "profile" in m
                 else (None, (0.0, length), (0.0, 0.0), ((0.0, 0.0), (length, length))))
        spreading = number(m.get("axial_spread", 0.0), f"member {i} axial_spread", Number(0.0, 1e3))
        members.append((m["kind"], start, end, size.get("thickness_mm", 0.0),
                        size.get("depth_mm", 0.0), int(hinge), name, *shape, spreading))
    supports = []
    for i, sp in enumerate(items(data["supports"], "supports")):
        table(sp, f"support {i}", {"node", "dofs"}, ("node", "dofs"))
        dofs = sp["dofs"]
        if not (isinstance(dofs, list) and dofs and all(isinstance(d, str) and d in DOF_NAMES for d in dofs)):
            fail(f"support {i} dofs = {dofs!r}: must be a non-empty list from {', '.join(DOF_NAMES)}")
        supports.append((index(sp["node"], f"support {i} node", n), tuple(dofs)))
    ports = {}
    for port in ("input", "output"):
        p = table(data[port], port, {"node", "direction"}, ("node", "direction"))
        ports[port] = (index(p["node"], f"{port} node", n), direction(p["direction"], f"{port} direction"))
    kind, start, end, thick, depth, hinge, name, profile, neck, radius, fillet, spreading = zip(*members)
    return BeamModel(
        nodes=np.array(nodes, dtype=float),
        member_nodes=np.array([start, end], dtype=int).T.reshape(-1, 2),
        member_kind=kind,
        thickness_mm=np.array(thick),
        depth_mm=np.array(depth),
        hinge_number=np.array(hinge, dtype=int),
        member_name=name,
        supports=tuple(supports),
        input_node=ports["input"][0],
        input_direction=ports["input"][1],
        output_node=ports["output"][0],
        output_direction=ports["output"][1],
        E_MPa=E,
        nu=nu,
        material_name=str(mat.get("name", "custom")),
        profile_mm=profile,
        neck_mm=np.array(neck, dtype=float),
        root_radius_mm=np.array(radius, dtype=float),
        fillet_neck_mm=np.array(fillet, dtype=float),
        axial_spread=np.array(spreading, dtype=float),
    )


def _member_shape(m: dict, i: int, length: float, fail, number) -> tuple:
    """A member's thickness profile, neck stations, root radii and root fillet stations
    from its JSON entry."""
    if m["kind"] == "rigid":
        fail(f"member {i}: a rigid member has no thickness profile")
    prof = m["profile"]
    if not (isinstance(prof, list) and 2 <= len(prof) <= MAX_PROFILE_STATIONS
            and all(isinstance(p, list) and len(p) in (2, 3) for p in prof)):
        fail(f"member {i} profile = {reprlib.repr(prof)}: must be a list of 2 to "
             f"{MAX_PROFILE_STATIONS} [s, t] or [s, t, e] stations (mm; e the centroid's offset "
             "to the member's left, 0 if left out)")
    st = np.array([[number(v, f"member {i} profile {c}", _SIZE if c == "t" else _COORD)
                    for v, c in zip([*p, 0.0][:3], "ste")] for p in prof])
    if st[0, 0] != 0.0 or np.any(np.diff(st[:, 0]) < 0) or abs(st[-1, 0] - length) > 1e-6 * max(length, 1.0):
        fail(f"member {i} profile: stations must rise from 0 to the member's length {length:.6g} mm")
    def pair(key: str, default: list, rule: Number) -> tuple:
        value = m.get(key, default)
        if not (isinstance(value, list) and len(value) == 2):
            fail(f"member {i} {key} = {reprlib.repr(value)}: must be [start, end] (mm)")
        return tuple(number(v, f"member {i} {key}", rule) for v in value)

    neck = pair("neck_mm", [0.0, length], _COORD)
    radius = pair("root_radius_mm", [0.0, 0.0], Number(0.0, MAX_LENGTH_MM, unit="mm"))
    fillet = m.get("fillet_neck_mm", [[neck[0]] * 2, [neck[1]] * 2])
    if not (isinstance(fillet, list) and len(fillet) == 2
            and all(isinstance(f, list) and len(f) == 2 for f in fillet)):
        fail(f"member {i} fillet_neck_mm = {reprlib.repr(fillet)}: must be [[start left, start right], "
             "[end left, end right]] (mm)")
    fillet = tuple(tuple(number(v, f"member {i} fillet_neck_mm", _COORD) for v in f) for f in fillet)
    return st, neck, radius, fillet


def model_to_json(model: BeamModel) -> str:
    return json.dumps(model_to_dict(model), indent=1)


def load_model(path) -> BeamModel:
    """Read a beam-model JSON file."""
    try:
        with open(path, "rb") as fh:
            data = json.load(fh)
    except (json.JSONDecodeError, UnicodeDecodeError, RecursionError) as exc:
        raise GeometryError(f"{path}: malformed JSON: {str(exc).splitlines()[0][:200]}") from None
    return model_from_dict(data, source=str(path))
