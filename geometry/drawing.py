"""A picture of a design's profile like thesis Figure 48: hinge numbers, input and output
ports, phi1/phi2 and the footprint w x h. The profile comes from the CAD face (CadQuery,
imported when drawn)."""

from __future__ import annotations

import math
import textwrap

import numpy as np
from matplotlib.figure import Figure

from geometry import style
from geometry.layout import kinematic_amplification, make_layout, make_parts
from geometry.params import Design

style.use()


_BODY, _EDGE, _HINGE, _PORT, _DIM = "#e8dcc0", "#333333", "#b22222", "#1f4e9c", "#555555"


def _compound_path(face):
    """A matplotlib Path of the profile (outline and holes) from the CAD face."""
    from matplotlib.path import Path as MPath

    from geometry.cad import face_loops, flatten_loop

    outline, holes = face_loops(face)
    verts, codes = [], []
    for loop in [outline, *holes]:
        pts = flatten_loop(loop)
        verts += [*pts, pts[0]]
        codes += [MPath.MOVETO] + [MPath.LINETO] * (len(pts) - 1) + [MPath.CLOSEPOLY]
    return MPath(np.array(verts), codes)


def _angle_mark(ax, centre, start_deg, end_deg, radius, label, ref_end, label_offset):
    """An angle arc at ``centre`` from ``start_deg`` to ``end_deg`` (deg, CCW from +x) with a
    dashed reference line to ``ref_end``, labelled at ``ref_end + label_offset``."""
    from matplotlib.patches import Arc

    lo, hi = sorted((start_deg, end_deg))
    ax.plot(*np.array([centre, ref_end]).T, ls="--", lw=0.7, color=_DIM)
    ax.add_patch(Arc(centre, 2 * radius, 2 * radius, theta1=lo, theta2=hi, lw=0.9, color=_PORT))
    ax.text(*(np.asarray(ref_end) + label_offset), label, ha="center", va="center",
            fontsize=10, color=_PORT)


def _dimension(ax, a, b, text, offset_xy, rotation=0):
    """A dimension line between points a and b, drawn ``offset_xy`` away, with extension lines."""
    a, b, off = np.asarray(a, float), np.asarray(b, float), np.asarray(offset_xy, float)
    for p in (a, b):
        ax.plot(*np.array([p, p + off * 1.1]).T, lw=0.5, color=_DIM)
    ax.annotate("", xy=a + off, xytext=b + off,
                arrowprops=dict(arrowstyle="<->", lw=0.8, color=_DIM, shrinkA=0, shrinkB=0))
    mid = (a + b) / 2 + off * 1.6
    ax.text(*mid, text, ha="center", va="center", rotation=rotation, fontsize=9, color=_DIM)


def plot_profile(design: Design, ax) -> None:
    """Draw the profile of a (feasible) design on a matplotlib axes, in mm."""
    from matplotlib.patches import PathPatch, Rectangle

    from geometry.cad import profile_face

    lay = make_layout(design)
    parts = make_parts(lay)
    W, H = design.width_mm, design.height_mm
    ax.add_patch(PathPatch(_compound_path(profile_face(design, lay)), facecolor=_BODY,
                           edgecolor=_EDGE, lw=0.9))

    # hinge numbers, set off from the neck on the side away from the body's centre line
    for p in (q for q in parts if q.kind == "hinge"):
        a, b = p.axis
        mid = (a + b) / 2
        u = (b - a) / np.linalg.norm(b - a)
        n = np.array([-u[1], u[0]])
        if p.hinge <= 8:
            n = n if n[0] * mid[0] > 0 else -n          # outwards, away from x = 0
        else:
            n = n if n[1] > 0 else -n                    # middle branch: upwards
        pos = mid + 1.4 * n
        ax.plot(*np.array([mid, mid + 0.9 * n]).T, lw=0.5, color=_HINGE)
        ax.text(*pos, str(p.hinge), ha="center", va="center", fontsize=7.5, color=_HINGE,
                fontweight="bold")

    # input port: the load on the top plate's centre
    top = lay.input_point
    ax.annotate("", xy=top, xytext=top + (0, 3.2),
                arrowprops=dict(arrowstyle="-|>", lw=1.5, color=_PORT))
    ax.text(top[0] + 0.6, top[1] + 2.2, "input $F$", fontsize=9, color=_PORT, va="center")

    # output port: mirror on the output body, fiber rising from the base to face it
    out = lay.output_point
    mirror_w = min(design.platform_width_mm, 3.0)
    ax.add_patch(Rectangle((out[0] - mirror_w / 2, out[1] - 0.35), mirror_w, 0.35,
                           facecolor="#8fb3d9", edgecolor=_PORT, lw=0.6, zorder=3))
    ax.plot([0, 0], [lay.y_base - design.plate_thickness_mm / 2, lay.post_top], lw=1.6,
            color="#e07b00", zorder=3, solid_capstyle="butt")
    ax.annotate("", xy=out + (0, -1.0), xytext=out + (0, -0.4),
                arrowprops=dict(arrowstyle="-|>", lw=1.2, color=_PORT))
    ax.annotate("output (mirror)", xy=out + (mirror_w / 2, -0.2), xytext=(2.2, out[1] - 5.5),
                fontsize=8, color=_PORT, arrowprops=dict(arrowstyle="-", lw=0.5, color=_PORT))
    ax.annotate("fiber", xy=(0, (lay.y_base + lay.post_top) / 2), xytext=(2.2, lay.y_base + 2.0),
                fontsize=8, color="#e07b00", arrowprops=dict(arrowstyle="-", lw=0.5, color="#e07b00"))

    # angles: phi1 at the left base hinge (from the vertical; the right side carries the
    # output and fiber labels), phi2 at the left knee
    p0, p1 = lay.P0, lay.P1
    lean = math.degrees(math.atan2(p1[1] - p0[1], p1[0] - p0[0]))
    _angle_mark(ax, p0, 90.0, lean, 7.0, r"$\varphi_1$", p0 + (0, 8.5), (0.9, 0.3))
    if not design.is_basis:
        k, q = lay.K, lay.Q
        rise = math.degrees(math.atan2(q[1] - k[1], q[0] - k[0]))
        _angle_mark(ax, k, 0.0, rise, 4.0, r"$\varphi_2$", k + (5.5, 0), (0.9, -0.6))

    # footprint w x h
    _dimension(ax, (-W / 2, 0), (W / 2, 0), f"w = {W:g} mm", (0, -1.6))
    _dimension(ax, (-W / 2, 0), (-W / 2, H), f"h = {H:g} mm", (-1.6, 0), rotation=90)

    phi = f"$\\varphi_1$ = {design.phi1_deg:g}°"
    if not design.is_basis:
        phi += f", $\\varphi_2$ = {design.phi2_deg:g}°"
    a_kin = kinematic_amplification(design.phi1_deg, design.phi2_deg)
    ax.set_title(f"{design.name}: {phi}, hinges {design.hinge_set}, "
                 f"$A_{{kin}}$ = {a_kin:.2f}", fontsize=10)
    ax.text(0.5, 0.0, textwrap.fill(hinge_thickness_note(design), 58), transform=ax.transAxes,
            ha="center", va="top", fontsize=8.5, color=_HINGE)
    ax.set_xlim(-W / 2 - 4.5, W / 2 + 2.0)
    ax.set_ylim(-4.5, H + 4.0)
    ax.set_aspect("equal")
    ax.set_axis_off()


def hinge_thickness_note(design: Design) -> str:
    """The hinge thicknesses, hinges of equal thickness (to 0.01 mm) together:
    ``"hinge thickness: 1-8 0.50 mm, 9-12 0.30 mm"``."""
    groups: dict[str, list[int]] = {}
    for number, t in enumerate(design.hinge_thickness_mm, start=1):
        groups.setdefault(f"{t:.2f}", []).append(number)

    def numbers(ns: list[int]) -> str:
        runs, start = [], ns[0]
        for prev, n in zip(ns, ns[1:] + [None]):
            if n != prev + 1:
                runs.append(f"{start}-{prev}" if prev > start else f"{start}")
                start = n
        return ", ".join(runs)

    return "hinge thickness: " + "; ".join(f"{numbers(ns)} {t} mm" for t, ns in groups.items())


def profile_figure(design: Design) -> Figure:
    """A Figure of the profile of a (feasible) design, in mm (cf. thesis Figure 48)."""
    fig = Figure(figsize=(5.0, 5.6), layout="tight")
    plot_profile(design, fig.subplots())
    return fig


def dimensioned_figure(design: Design, kerf_mm: float | None = None) -> Figure:
    """The shop drawing of a design (mm, deg): the profile with its hinge numbers, angles,
    footprint and the input and output points, and beside it the table of every used hinge's
    drawn thickness and flexible length, the link and plate widths and the two angles;
    ``kerf_mm``: the jet the DXF is compensated for (stated in the title block)."""
    lay = make_layout(design)
    hinges = sorted((p for p in make_parts(lay) if p.kind == "hinge"), key=lambda p: p.hinge)
    fig = Figure(figsize=(9.0, 5.8), layout="tight")
    ax, tab = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.15, 1.0]})
    plot_profile(design, ax)
    for pt, dx, dy in ((lay.input_point, -1.6, 0.9), (lay.output_point, -1.8, -3.5)):
        ax.plot(*pt, marker="o", ms=3.5, color=_PORT, zorder=4)
        ax.text(pt[0] + dx, pt[1] + dy, f"({pt[0]:.2f}, {pt[1]:.2f})", ha="right", fontsize=7, color=_PORT)
    tab.set_axis_off()
    rows = [["hinge", "t (mm)", "L (mm)"]]
    rows += [[str(p.hinge), f"{p.width:.4f}", f"{np.linalg.norm(p.axis[1] - p.axis[0]):.3f}"] for p in hinges]
    t = tab.table(cellText=rows, loc="upper left", cellLoc="center", colWidths=[0.16, 0.22, 0.22],
                  bbox=[0.0, 1.0 - 0.052 * len(rows), 0.6, 0.052 * len(rows)])
    t.set_fontsize(8)
    angles = f"phi1 = {design.phi1_deg:.2f} deg" + ("" if design.is_basis else f", phi2 = {design.phi2_deg:.2f} deg")
    notes = [angles,
             f"footprint {design.width_mm:g} x {design.height_mm:g} mm, sheet {design.sheet_thickness_mm:g} mm",
             f"link width {design.link_width_mm:g} mm, plates {design.plate_thickness_mm:g} mm, "
             f"platform {design.platform_width_mm:g} x {design.platform_thickness_mm:g} mm",
             f"knees {design.knee_width_mm:g} x {design.knee_height_mm:g} mm, "
             f"fiber post {design.fiber_post_width_mm:g} mm",
             f"input ({lay.input_point[0]:.2f}, {lay.input_point[1]:.2f}) mm, "
             f"output ({lay.output_point[0]:.2f}, {lay.output_point[1]:.2f}) mm",
             f"material {design.material.name}; "
             + ("drawing (no kerf compensation)" if not kerf_mm else f"DXF: jet centre path, kerf {kerf_mm:g} mm")]
    tab.text(0.0, 1.0 - 0.052 * len(rows) - 0.04, "\n".join(notes), va="top", fontsize=7.5,
             transform=tab.transAxes, family="monospace")
    return fig
