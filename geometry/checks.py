"""Feasibility rules of a design, checked before anything is drawn (DESIGN section 3).

Every rule has a name; :func:`check_design` reports each one (pass or fail, with the
numbers), :func:`assert_feasible` raises :class:`InfeasibleDesignError` for the first
failure. Pairwise distances between parts are computed in one vectorised pass so a sweep
can check thousands of designs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from geometry.errors import InfeasibleDesignError
from geometry.layout import Layout, Part, _bar, make_layout, make_parts
from geometry.params import Design

#: Smallest mirror the platform must carry (mm): DESIGN section 3 ("a mirror of about 3-5 mm").
MIRROR_MIN_MM = 3.0

RULES = ("angle_limits", "min_feature", "hinge_fits", "footprint", "no_crossing",
         "kerf_gap", "platform_inside")


@dataclass(frozen=True)
class RuleResult:
    rule: str
    ok: bool
    message: str


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


def phi2_limit_deg(d: Design) -> float:
    """Largest phi2 (deg) before the platform meets the top plate (less one kerf)."""
    lay = make_layout(d.replace(phi2_deg=45.0) if d.is_basis else d)
    span = -d.platform_width_mm / 2 - lay.K[0]
    head = lay.y_top - d.kerf_mm - d.platform_thickness_mm / 2 - lay.K[1]
    return math.degrees(math.atan2(head, span))


def _free_polygons(parts: list[Part]) -> np.ndarray:
    """(P, 4, 2) polygons with hinges cut back to their flexible length (no root overlap)."""
    return np.array([_bar(p.axis[0], p.axis[1], p.width) if p.kind == "hinge" else p.polygon
                     for p in parts])


def _pair_distances(poly: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distances between convex quads (P, P) and an overlap mask (separating-axis test)."""
    edges_a = poly
    edges_b = np.roll(poly, -1, axis=1)
    # point (of i) to segment (of j) distances: (P, P, 4 points, 4 segments)
    p = poly[:, None, :, None, :]
    a = edges_a[None, :, None, :, :]
    b = edges_b[None, :, None, :, :]
    ab = b - a
    t = np.clip(np.sum((p - a) * ab, -1) / np.sum(ab * ab, -1), 0.0, 1.0)
    dist = np.linalg.norm(p - (a + t[..., None] * ab), axis=-1).min(axis=(2, 3))
    dist = np.minimum(dist, dist.T)
    # separating axes: edge normals of both polygons
    normals = np.stack([-(edges_b - edges_a)[..., 1], (edges_b - edges_a)[..., 0]], -1)  # (P,4,2)
    proj = np.einsum("pvk,qnk->pqnv", poly, normals)  # (P points-poly, Q normal-poly, 4 n, 4 v)
    lo, hi = proj.min(-1), proj.max(-1)                 # (P, Q, 4)
    own = np.arange(len(poly))
    lo_own, hi_own = lo[own, own], hi[own, own]         # (Q, 4): q on its own normals
    gap_on_q = (hi < lo_own[None] - 1e-9) | (lo > hi_own[None] + 1e-9)  # (P, Q, 4)
    separated = gap_on_q.any(-1)
    separated = separated | separated.T
    return dist, ~separated


def _adjacent(parts: list[Part], lay: Layout) -> np.ndarray:
    """Pairs of parts joined by design (a hinge and its link or root body; a post and base)."""
    names = [p.name for p in parts]
    idx = {n: i for i, n in enumerate(names)}
    adj = np.eye(len(parts), dtype=bool)

    def join(a, b):
        if a in idx and b in idx:
            adj[idx[a], idx[b]] = adj[idx[b], idx[a]] = True

    join("fiber post", "base plate")
    roots = {1: "base plate", 2: "left knee", 3: "left knee", 4: "top plate", 5: "top plate",
             6: "right knee", 7: "right knee", 8: "base plate", 9: "left knee", 10: "platform",
             11: "platform", 12: "right knee"}
    # each member chain is three consecutive parts: hinge, link, hinge
    for i, p in enumerate(parts):
        if p.kind == "link":
            h1, h2 = parts[i - 1], parts[i + 1]
            for h in (h1, h2):
                join(h.name, p.name)
                join(h.name, roots[h.hinge])
                join(p.name, roots[h.hinge])  # a link may come close to its own root body
            join(h1.name, h2.name)
    # hinges rooted in the same body touch through it
    for a in parts:
        for b in parts:
            if a.kind == "hinge" and b.kind == "hinge" and roots[a.hinge] == roots[b.hinge]:
                join(a.name, b.name)
    return adj


def check_design(d: Design) -> FeasibilityReport:
    """Evaluate every rule in :data:`RULES` on a design."""
    lay = make_layout(d)
    res: list[RuleResult] = []

    def add(rule, ok, msg):
        res.append(RuleResult(rule, bool(ok), msg))

    lim1 = phi1_limit_deg(d)
    ok = d.phi1_deg <= lim1
    msg = f"phi1_deg = {d.phi1_deg:g}: must be <= {lim1:.2f} deg (side links reach the fiber post)"
    if ok and not d.is_basis:
        lim2 = phi2_limit_deg(d)
        ok = d.phi2_deg <= lim2
        msg = f"phi2_deg = {d.phi2_deg:g}: must be <= {lim2:.2f} deg (platform meets the top plate)"
    add("angle_limits", ok, msg)

    used = d.hinge_thickness_mm[:8] if d.is_basis else d.hinge_thickness_mm
    thinnest = min(used)
    which = 1 + list(d.hinge_thickness_mm).index(thinnest)
    webs = {"link_width_mm": d.link_width_mm, "plate_thickness_mm": d.plate_thickness_mm,
            "platform_thickness_mm": d.platform_thickness_mm, "knee_width_mm": d.knee_width_mm}
    web, wval = min(webs.items(), key=lambda kv: kv[1])
    if thinnest < d.min_feature_mm:
        add("min_feature", False, f"hinge {which} thickness = {thinnest:g} mm: must be >= "
            f"min_feature_mm = {d.min_feature_mm:g} mm (what the cutting process can hold)")
    elif wval < d.min_feature_mm:
        add("min_feature", False, f"{web} = {wval:g} mm: must be >= min_feature_mm = {d.min_feature_mm:g} mm")
    else:
        add("min_feature", True, f"thinnest hinge {thinnest:g} mm >= {d.min_feature_mm:g} mm")

    parts = make_parts(lay)
    links = [p for p in parts if p.kind == "link"]
    shortest = min(links, key=lambda p: np.linalg.norm(p.axis[1] - p.axis[0]))
    llen = float(np.linalg.norm(shortest.axis[1] - shortest.axis[0]))
    add("hinge_fits", llen >= d.link_width_mm,
        f"hinge_length_mm = {d.hinge_length_mm:g}: leaves the {shortest.name} only {llen:.2f} mm "
        f"between its hinges; must be >= link_width_mm = {d.link_width_mm:g} mm")

    poly = _free_polygons(parts)
    lo, hi = poly.reshape(-1, 2).min(0), poly.reshape(-1, 2).max(0)
    tol = 1e-9
    inside = (lo[0] >= -d.width_mm / 2 - tol and hi[0] <= d.width_mm / 2 + tol
              and lo[1] >= -tol and hi[1] <= d.height_mm + tol)
    add("footprint", inside, f"body spans x [{lo[0]:.2f}, {hi[0]:.2f}], y [{lo[1]:.2f}, {hi[1]:.2f}] mm: "
        f"must fit the footprint width_mm = {d.width_mm:g} x height_mm = {d.height_mm:g}")

    dist, overlap = _pair_distances(poly)
    adj = _adjacent(parts, lay)
    free = ~adj
    crossing = np.argwhere(np.triu(overlap & free, 1))
    if len(crossing):
        i, j = crossing[0]
        add("no_crossing", False, f"{parts[i].name} crosses {parts[j].name} "
            f"(phi1_deg = {d.phi1_deg:g}, phi2_deg = {d.phi2_deg})")
    else:
        add("no_crossing", True, "no part crosses another")
    gaps = np.where(np.triu(free, 1) & ~overlap, dist, np.inf)
    i, j = np.unravel_index(np.argmin(gaps), gaps.shape)
    add("kerf_gap", gaps[i, j] >= d.kerf_mm - 1e-9,
        f"gap between {parts[i].name} and {parts[j].name} = {gaps[i, j]:.3f} mm: must be >= kerf_mm = {d.kerf_mm:g} mm")

    if d.is_basis:
        add("platform_inside", d.fiber_clearance_mm >= d.kerf_mm,
            f"fiber_clearance_mm = {d.fiber_clearance_mm:g}: must be >= kerf_mm = {d.kerf_mm:g} mm")
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
        add("platform_inside", not msgs, "; ".join(msgs) or "platform inside the hexagon, mirror fits")
    return FeasibilityReport(d, tuple(res))


def assert_feasible(d: Design) -> None:
    """Raise :class:`InfeasibleDesignError` naming the first rule a design breaks."""
    fail = check_design(d).first_failure
    if fail is not None:
        raise InfeasibleDesignError(fail.rule, fail.message)
