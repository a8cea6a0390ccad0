"""Figures of the mechanics: the continuum FE's stress field (``dacm verify``).

Functions return :class:`matplotlib.figure.Figure` objects; write them with
:func:`geometry.atomic.save_figure`.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure
from matplotlib.tri import Triangulation

from geometry import style

style.use()


def stress_field_figure(result, design, title: str = "", hinge_stress_MPa: dict | None = None,
                        clip_percentile: float = 99.8) -> Figure:
    """Von Mises stress (MPa) of a :class:`~sensor.mechanics.continuum.ContinuumResult` on
    its deformed mesh (true scale), with ``hinge_stress_MPa`` written on each hinge of
    ``design``.

    The colour scale runs to the larger of 1.2 x the material's allowable stress (marked on
    the colour bar) and ``clip_percentile`` of the corner values, so the allowable is always on
    the scale and the few elements at sharp re-entrant corners (singular in linear
    elasticity) do not wash out the field; values above the top get the top colour (the
    colour bar's arrow).
    """
    xy = result.points + result.displacement_mm
    tri = Triangulation(xy[:, 0], xy[:, 1], result.triangles)
    undeformed = Triangulation(result.points[:, 0], result.points[:, 1], result.triangles)
    value = result.von_mises_MPa.max(axis=1)
    allowable = design.material.allowable_stress_MPa
    top = float(np.percentile(result.von_mises_MPa, clip_percentile))
    if np.isfinite(allowable):
        top = max(top, 1.2 * allowable)
    fig = Figure(figsize=(10.0, 5.6), layout="constrained")
    whole, zoom = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.25, 1.0]})
    centres = _hinge_centres(result, design, hinge_stress_MPa or {})
    for ax in (whole, zoom):
        ax.triplot(undeformed, color="0.75", lw=0.15, zorder=0)
        art = ax.tripcolor(tri, facecolors=value, cmap="viridis", vmin=0.0, vmax=top, shading="flat")
        ax.set_aspect("equal")
        ax.set_xlabel("x (mm)")
    whole.set_ylabel("y (mm)")
    for h, (x, y) in centres.items():
        whole.annotate(f"{h}: {hinge_stress_MPa[h]:.0f}", (x, y), xytext=(x + (1.6 if x > 0 else -1.6), y),
                       fontsize=8, color="crimson", ha="center", va="center",
                       bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.8})
    if centres:
        worst = max(centres, key=lambda h: hinge_stress_MPa[h])
        x, y = centres[worst]
        zoom.set_xlim(x - 2.0, x + 2.0)
        zoom.set_ylim(y - 1.6, y + 1.6)
        zoom.set_title(f"hinge {worst} (grey: undeformed mesh)")
    bar = fig.colorbar(art, ax=[whole, zoom], shrink=0.85, extend="max", label="von Mises stress (MPa)")
    if np.isfinite(allowable):
        bar.ax.axhline(allowable, color="crimson", lw=2.5)
        bar.ax.text(-0.15, allowable, f"allowable\n{allowable:g} MPa", transform=bar.ax.get_yaxis_transform(),
                    ha="right", va="center", fontsize=8.5, color="crimson")
    fig.suptitle(title)
    return fig


def _hinge_centres(result, design, hinges) -> dict:
    """Deformed position (mm) of each hinge's mid-point (the mesh point nearest it)."""
    from geometry.layout import make_layout, make_parts

    out = {}
    for p in make_parts(make_layout(design)):
        if p.kind == "hinge" and p.hinge in hinges:
            node = int(np.argmin(np.linalg.norm(result.points - p.axis.mean(axis=0), axis=1)))
            out[p.hinge] = result.points[node] + result.displacement_mm[node]
    return out


def hinge_stress_figure(stresses: dict, allowable_MPa: float, title: str = "") -> Figure:
    """Each hinge's peak stress (MPa; :class:`~sensor.mechanics.stress.HingeStress`, root
    stress concentration included) against the material's allowable stress (the line), the
    bars coloured on the same scale as :func:`stress_field_figure` (0 to 1.2 x allowable)."""
    from matplotlib import colormaps
    from matplotlib.colors import Normalize

    hinges = sorted(stresses)
    peaks = np.array([stresses[h].peak_MPa for h in hinges])
    top = max(1.2 * allowable_MPa, float(peaks.max()) * 1.05) if np.isfinite(allowable_MPa) else float(peaks.max()) * 1.2
    norm = Normalize(0.0, 1.2 * allowable_MPa if np.isfinite(allowable_MPa) else top)
    fig = Figure(figsize=(6.4, 3.4), layout="constrained")
    ax = fig.subplots()
    ax.bar([str(h) for h in hinges], peaks, color=colormaps["viridis"](norm(peaks)), edgecolor="k", lw=0.5)
    if np.isfinite(allowable_MPa):
        ax.axhline(allowable_MPa, color="crimson", lw=2, label=f"allowable {allowable_MPa:g} MPa")
        ax.legend(loc="upper left")
    ax.set(xlabel="hinge (numbers as in the profile)", ylabel="peak stress at full scale (MPa)", ylim=(0, top),
           title=title)
    return fig
