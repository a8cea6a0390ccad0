"""Feasibility rules of a design, checked before anything is drawn (DESIGN section 3).

Every rule has a name; :func:`check_design` reports each one (pass or fail, with the
numbers), :func:`assert_feasible` raises :class:`InfeasibleDesignError` for the first
failure. Pairwise distances between parts are computed in one vectorised pass so a sweep
can check thousands of designs.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from geometry.errors import InfeasibleDesignError
from geometry.layout import Layout, Part, bar, make_layout, make_parts
from geometry.params import Design

#: Smallest mirror the platform must carry (mm): DESIGN section 3 ("a mirror of about 3-5 mm").
MIRROR_MIN_MM = 3.0

RULES = ("angle_limits", "min_feature", "hinge_fits", "hinge_on_face", "footprint", "no_crossing",
         "kerf_gap", "platform_inside")


@dataclass(frozen=True)
class RuleResult:
    """One rule's verdict; ``margin`` is how far the design is inside the rule's limit
    (negative: outside), in ``unit`` (NaN when the rule has no single number)."""

    rule: str
    ok: bool
    message: str
    margin: float = math.nan
    unit: str = ""


@dataclass(frozen=True)
class FeasibilityReport:
    design: Design
    results: tuple[RuleResult, ...]

    @property
    def feasible(self) -> bool:
        return all(r.ok for r in self.results)

    @property
    def first_failure(self) -> RuleResult | None:
        return next((r for r in self.results if not r.ok), None)


def phi1_limit_deg(d: Design) -> float:
    """Largest phi1 (deg) before the side links' roots reach the fiber post's column."""
    rise = (d.height_mm - 2 * d.plate_thickness_mm - d.knee_height_mm) / 2
    room = d.width_mm / 2 - d.knee_width_mm / 2 - d.fiber_post_width_mm / 2 - d.link_width_mm
    return math.degrees(math.atan2(max(room, 0.0), rise))


def phi2_limit_deg(d: Design, layout: Layout | None = None) -> float:
    """Largest phi2 (deg) before the platform meets the top plate (less one kerf);
    ``layout``: the design's own, if at hand (a proposed body's)."""
    if d.is_basis:
        lay = make_layout(d.replace(phi2_deg=45.0))
    else:
        lay = layout if layout is not None else make_layout(d)
    span = -d.platform_width_mm / 2 - lay.K[0]
    head = lay.y_top - d.kerf_mm - d.platform_thickness_mm / 2 - lay.K[1]
    return math.degrees(math.atan2(head, span))


def _free_polygons(parts: list[Part]) -> np.ndarray:
    """(P, 4, 2) polygons with hinges cut back to their flexible length (no root overlap)."""
    return np.array([bar(p.axis[0], p.axis[1], p.width) if p.kind == "hinge" else p.polygon
                     for p in parts])


#: Each vertex's successor round a quad (np.roll by -1, without its overhead).
_NEXT_VERTEX = np.array([1, 2, 3, 0])


def _pair_distances(A: np.ndarray, B: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distances between convex quads A[k] and B[k], (k, 4, 2) each, and an overlap mask
    (separating-axis test on the edge normals of both). Written per coordinate: numpy's
    reductions over a length-2 axis cost more than the arithmetic."""
    ax, ay, bx, by = A[..., 0], A[..., 1], B[..., 0], B[..., 1]        # (k, 4)

    def point_to_edges(px, py, qx, qy):
        ex, ey = qx[:, _NEXT_VERTEX] - qx, qy[:, _NEXT_VERTEX] - qy     # (k, 4) edges
        sx, sy = qx[:, None, :], qy[:, None, :]                         # (k, 1, 4) starts
        ex, ey = ex[:, None, :], ey[:, None, :]
        dx, dy = px[:, :, None] - sx, py[:, :, None] - sy                # (k, 4, 4)
        t = np.clip((dx * ex + dy * ey) / (ex * ex + ey * ey), 0.0, 1.0)
        dx, dy = dx - t * ex, dy - t * ey
        return (dx * dx + dy * dy).min(axis=(1, 2))

    dist = np.sqrt(np.minimum(point_to_edges(ax, ay, bx, by), point_to_edges(bx, by, ax, ay)))
    separated = np.zeros(len(A), dtype=bool)
    for qx, qy in ((ax, ay), (bx, by)):
        nx, ny = -(qy[:, _NEXT_VERTEX] - qy)[:, :, None], (qx[:, _NEXT_VERTEX] - qx)[:, :, None]   # (k, 4, 1) normals
        pa = ax[:, None, :] * nx + ay[:, None, :] * ny                  # (k, normal, vertex)
        pb = bx[:, None, :] * nx + by[:, None, :] * ny
        separated |= ((pa.max(-1) < pb.min(-1) - 1e-9) | (pb.max(-1) < pa.min(-1) - 1e-9)).any(-1)
    return dist, ~separated


def _near_pairs(poly: np.ndarray, I: np.ndarray, J: np.ndarray) -> np.ndarray:
    """(n, k) mask of the pairs (I, J) of each design's parts, ``poly`` (n, P, 4, 2), that
    can hold its smallest distance or an overlap: those whose bounding boxes are no farther
    apart than the design's closest pair of centroids (an upper bound of that pair's
    distance), plus 1e-6 mm so that pairs the separating-axis test (1e-9 tolerance) would
    call touching stay in. Skipping the others leaves the rules' results, and which pair
    they name, unchanged."""
    lo, hi, centre = poly.min(axis=2), poly.max(axis=2), poly.mean(axis=2)   # (n, P, 2)
    gap = np.maximum(np.maximum(lo[:, J] - hi[:, I], lo[:, I] - hi[:, J]), 0.0)   # (n, k, 2)
    lower = np.sqrt(gap[..., 0] * gap[..., 0] + gap[..., 1] * gap[..., 1])
    step = centre[:, I] - centre[:, J]
    upper = np.sqrt(step[..., 0] ** 2 + step[..., 1] ** 2).min(axis=1, keepdims=True)
    return lower <= upper + 1e-6


def _near_distances(poly: np.ndarray, I: np.ndarray, J: np.ndarray) -> list[tuple]:
    """For each of n designs of one topology, ``poly`` (n, P, 4, 2): its near pairs (as
    indices into I, J), their distances and overlap mask; one vectorised pass for all."""
    near = _near_pairs(poly, I, J)
    which, pair = np.nonzero(near)
    dist, overlap = _pair_distances(poly[which, I[pair]], poly[which, J[pair]])
    cuts = np.cumsum(near.sum(axis=1))[:-1]
    return list(zip(np.split(pair, cuts), np.split(dist, cuts), np.split(overlap, cuts)))


_ROOTS = {1: "base plate", 2: "left knee", 3: "left knee", 4: "top plate left", 5: "top plate right",
          6: "right knee", 7: "right knee", 8: "base plate", 9: "left knee", 10: "platform left",
          11: "platform right", 12: "right knee"}


@functools.lru_cache(maxsize=8)
def _free_pairs(names: tuple[str, ...], kinds: tuple[str, ...], hinges: tuple[int, ...],
                bodies: tuple[str, ...]):
    """Index pairs (i < j) of parts not joined by design: a hinge is joined to its link and
    its root body, a link to its own hinges' roots, hinges rooted in one body to each
    other, the halves of a body to each other, and the fiber post to the base plate.
    Parts and bodies are named (a knee block's two halves are one body). Cached per
    topology."""
    parts_of: dict[str, list[int]] = {}
    for i, (n, b) in enumerate(zip(names, bodies)):
        parts_of.setdefault(n, []).append(i)
        if b != n:
            parts_of.setdefault(b, []).append(i)
    joined: set[tuple[int, int]] = set()

    def join(a, b):
        joined.update((min(i, j), max(i, j)) for i in parts_of.get(a, ()) for j in parts_of.get(b, ()) if i != j)

    for body in set(bodies):
        join(body, body)
    join("fiber post", "base plate")
    join("top plate left", "top plate right")
    join("platform left", "platform right")
    for i, kind in enumerate(kinds):
        if kind == "link":
            h1, h2 = i - 1, i + 1
            for h in (h1, h2):
                join(names[h], names[i])
                join(names[h], _ROOTS[hinges[h]])
                join(names[i], _ROOTS[hinges[h]])
            join(names[h1], names[h2])
    hinge_idx = [i for i, k in enumerate(kinds) if k == "hinge"]
    for a in hinge_idx:
        for b in hinge_idx:
            if a < b and _ROOTS[hinges[a]] == _ROOTS[hinges[b]]:
                joined.add((a, b))
    pairs = [(i, j) for i in range(len(names)) for j in range(i + 1, len(names)) if (i, j) not in joined]
    I, J = np.array(pairs).T
    return I, J


def check_design(d: Design) -> FeasibilityReport:
    """Evaluate every rule in :data:`RULES` on a design."""
    return check_designs([d])[0]


def check_designs(designs) -> list[FeasibilityReport]:
    """:func:`check_design` of each design in a sequence; the part distances of the designs
    that share a topology are computed in one vectorised pass (a sweep row checks 42)."""
    shapes = []
    for d in designs:
        lay = make_layout(d)
        parts = make_parts(lay)
        shapes.append((lay, parts, _free_polygons(parts)))
    groups: dict[tuple, list[int]] = {}
    for n, (_, parts, _) in enumerate(shapes):
        key = (tuple(p.name for p in parts), tuple(p.kind for p in parts), tuple(p.hinge for p in parts),
               tuple(p.body for p in parts))
        groups.setdefault(key, []).append(n)
    near: list = [None] * len(shapes)
    for key, members in groups.items():
        I, J = _free_pairs(*key)
        poly = np.stack([shapes[n][2] for n in members])
        for n, (pair, dist, overlap) in zip(members, _near_distances(poly, I, J)):
            near[n] = (I[pair], J[pair], dist, overlap)
    return [_report(d, *shape, *pairs) for d, shape, pairs in zip(designs, shapes, near)]


def _report(d: Design, lay, parts: list[Part], poly: np.ndarray, I: np.ndarray, J: np.ndarray,
            dist: np.ndarray, overlap: np.ndarray) -> FeasibilityReport:
    """The rules of one design, given its layout, parts, free polygons and its near part
    pairs (I, J) with their distances and overlap mask."""
    res: list[RuleResult] = []

    def add(rule, ok, msg, margin=math.nan, unit="mm"):
        res.append(RuleResult(rule, bool(ok), msg, float(margin), unit if math.isfinite(margin) else ""))

    lim1 = phi1_limit_deg(d)
    ok = d.phi1_deg <= lim1
    margin = lim1 - d.phi1_deg
    msg = f"phi1_deg = {d.phi1_deg:g}: must be <= {lim1:.2f} deg (side links reach the fiber post)"
    if ok and not d.is_basis:
        lim2 = phi2_limit_deg(d, lay)
        ok = d.phi2_deg <= lim2
        margin = min(margin, lim2 - d.phi2_deg)
        msg = f"phi2_deg = {d.phi2_deg:g}: must be <= {lim2:.2f} deg (platform meets the top plate)"
    add("angle_limits", ok, msg, margin, "deg")

    used = d.used_thickness_mm
    thinnest = min(used)
    which = 1 + list(d.hinge_thickness_mm).index(thinnest)
    webs = {"link_width_mm": d.link_width_mm, "plate_thickness_mm": d.plate_thickness_mm,
            "platform_thickness_mm": d.platform_thickness_mm, "knee_width_mm": d.knee_width_mm}
    web, wval = min(webs.items(), key=lambda kv: kv[1])
    margin = min(thinnest, wval) - d.min_feature_mm
    if thinnest < d.min_feature_mm:
        add("min_feature", False, f"hinge {which} thickness = {thinnest:g} mm: must be >= "
            f"min_feature_mm = {d.min_feature_mm:g} mm (what the cutting process can hold)", margin)
    elif wval < d.min_feature_mm:
        add("min_feature", False, f"{web} = {wval:g} mm: must be >= min_feature_mm = {d.min_feature_mm:g} mm", margin)
    else:
        add("min_feature", True, f"thinnest hinge {thinnest:g} mm >= {d.min_feature_mm:g} mm", margin)

    links = [p for p in parts if p.kind == "link"]
    lengths = [math.hypot(*(p.axis[1] - p.axis[0])) for p in links]
    llen = min(lengths)
    shortest = links[lengths.index(llen)]
    add("hinge_fits", llen >= d.link_width_mm,
        f"hinge_length_mm = {d.hinge_length_mm:g}: leaves the {shortest.name} only {llen:.2f} mm "
        f"between its hinges; must be >= link_width_mm = {d.link_width_mm:g} mm", llen - d.link_width_mm)

    # a hinge leaning from its face's normal meets it over t / cos(lean): the knees' and the
    # platform's faces are short, and a neck wider than its face overhangs the body's corner
    meets = []
    for sm in lay.side_members:
        for h, face in zip(sm.hinges, sm.faces):
            t = d.hinge_thickness_mm[h - 1]
            meets.append((face.across - t / math.cos(math.radians(sm.lean_deg)), h, t, sm.lean_deg, face))
    room, h, t, lean_deg, face = min(meets, key=lambda m: m[0])
    add("hinge_on_face", room >= 0.0,
        f"hinge {h} thickness = {t:g} mm: leaning {lean_deg:g} deg, it meets the {face.body} over "
        f"{face.across - room:.2f} mm; must be <= the face's {face.across:g} mm", room)

    lo, hi = poly.reshape(-1, 2).min(0), poly.reshape(-1, 2).max(0)
    tol = 1e-9
    inside = (lo[0] >= -d.width_mm / 2 - tol and hi[0] <= d.width_mm / 2 + tol
              and lo[1] >= -tol and hi[1] <= d.height_mm + tol)
    add("footprint", inside, f"body spans x [{lo[0]:.2f}, {hi[0]:.2f}], y [{lo[1]:.2f}, {hi[1]:.2f}] mm: "
        f"must fit the footprint width_mm = {d.width_mm:g} x height_mm = {d.height_mm:g}",
        min(lo[0] + d.width_mm / 2, d.width_mm / 2 - hi[0], lo[1], d.height_mm - hi[1]))

    if overlap.any():
        k = int(np.argmax(overlap))
        add("no_crossing", False, f"{parts[I[k]].body} crosses {parts[J[k]].body} "
            f"(phi1_deg = {d.phi1_deg:g}, phi2_deg = {d.phi2_deg})")
    else:
        add("no_crossing", True, "no part crosses another")
    gaps = np.where(overlap, np.inf, dist)
    k = int(np.argmin(gaps))
    add("kerf_gap", gaps[k] >= d.kerf_mm - 1e-9,
        f"gap between {parts[I[k]].body} and {parts[J[k]].body} = {gaps[k]:.3f} mm: must be >= kerf_mm = {d.kerf_mm:g} mm",
        gaps[k] - d.kerf_mm)

    if d.is_basis:
        add("platform_inside", d.fiber_clearance_mm >= d.kerf_mm,
            f"fiber_clearance_mm = {d.fiber_clearance_mm:g}: must be >= kerf_mm = {d.kerf_mm:g} mm",
            d.fiber_clearance_mm - d.kerf_mm)
    else:
        top = lay.output_point[1] + d.platform_thickness_mm
        msgs = []
        if d.platform_width_mm < MIRROR_MIN_MM:
            msgs.append(f"platform_width_mm = {d.platform_width_mm:g}: must be >= {MIRROR_MIN_MM:g} mm to carry the mirror")
        if top > lay.y_top - d.kerf_mm:
            msgs.append(f"platform top at y = {top:.2f} mm: must stay below the top plate ({lay.y_top:g} mm) by the kerf")
        if lay.post_top <= lay.y_base:
            msgs.append(f"mirror at y = {lay.output_point[1]:.2f} mm leaves no room for the fiber post "
                        f"(fiber_clearance_mm = {d.fiber_clearance_mm:g})")
        add("platform_inside", not msgs, "; ".join(msgs) or "platform inside the hexagon, mirror fits",
            min(d.platform_width_mm - MIRROR_MIN_MM, lay.y_top - d.kerf_mm - top))
    return FeasibilityReport(d, tuple(res))


def assert_feasible(d: Design) -> None:
    """Raise :class:`InfeasibleDesignError` naming the first rule a design breaks."""
    fail = check_design(d).first_failure
    if fail is not None:
        raise InfeasibleDesignError(fail.rule, fail.message)
