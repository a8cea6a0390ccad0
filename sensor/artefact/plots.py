"""Figures of an artefact prediction: three orthogonal slices through the sensor (x-y at the
sheet's mid-plane, x-z at the mirror, y-z through the fiber), with the sensor's outline.

:func:`field_figure` shows the field offset (ppm, and Hz at B0 on the colour bar);
:func:`image_figure` the simulated gradient-echo magnitude with the artefact region
(signal loss above 30 %) drawn. Both return a ``matplotlib.figure.Figure``.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from geometry.layout import make_layout
from sensor.artefact.field import offset_hz
from sensor.artefact.prediction import SIGNAL_LOSS_THRESHOLD, Artefact

#: (title, axis normal to the slice, horizontal axis, vertical axis).
_VIEWS = (("x-y, sheet mid-plane", 2, 0, 1), ("x-z, at the mirror", 1, 0, 2),
          ("y-z, through the fiber", 0, 1, 2))
_NAMES = "xyz"


def slice_points(a: Artefact) -> tuple[float, float, float]:
    """The slice positions (mm): x = 0 (fiber), y at the mirror, z at the sheet's mid-plane."""
    lay = make_layout(a.design)
    return 0.0, float(lay.output_point[1]), a.design.sheet_thickness_mm / 2.0


def _cut(volume: np.ndarray, grid, normal: int, at_mm: float) -> np.ndarray:
    """The slice of ``volume`` normal to ``normal`` through ``at_mm``, (horizontal, vertical)."""
    point = [0.0, 0.0, 0.0]
    point[normal] = at_mm
    return np.take(volume, grid.index(point)[normal], axis=normal)


def _extent(grid, u: int, v: int) -> list[float]:
    e = [grid.edges(u), grid.edges(v)]
    return [e[0][0], e[0][-1], e[1][0], e[1][-1]]


def _panels(fig: Figure, title: str):
    fig.suptitle(title, fontsize=10)
    return fig.subplots(1, 3, width_ratios=(85, 85, 90))


def _outline(ax, a: Artefact, normal: int, u: int, v: int, at: float, colour: str) -> None:
    g = a.scene.grid
    ax.contour(g.centres(u), g.centres(v), _cut(a.scene.solid, g, normal, at).T, levels=[0.5],
               colors=colour, linewidths=0.7)


def field_figure(a: Artefact) -> Figure:
    """The field offset ΔB/B0 (ppm) on three slices, with the sensor's outline."""
    g, p = a.scene.grid, a.protocol
    medium = a.distance_mm > 0
    lim = float(np.percentile(np.abs(a.field_ppm[medium]), 99.9)) or 1e-3
    fig = Figure(figsize=(14, 4.2), layout="constrained")
    b = ", ".join(f"{v:.2g}" for v in a.b0_direction)
    axes = _panels(fig, f"{a.design.name} ({a.body_material}) in {a.scene.medium}: field offset, "
                        f"B0 = {p.b0_T:g} T along ({b}), field voxel {g.voxel_mm:g} mm")
    at = slice_points(a)
    for ax, (title, n, u, v) in zip(axes, _VIEWS):
        im = ax.imshow(_cut(a.field_ppm, g, n, at[n]).T, origin="lower", extent=_extent(g, u, v),
                       cmap="RdBu_r", vmin=-lim, vmax=lim, interpolation="nearest")
        _outline(ax, a, n, u, v, at[n], "k")
        ax.set(title=f"{title} ({_NAMES[n]} = {at[n]:.1f} mm)", xlabel=f"{_NAMES[u]} (mm)",
               ylabel=f"{_NAMES[v]} (mm)")
        ax.title.set_fontsize(9)
    bar = fig.colorbar(im, ax=list(axes), shrink=0.9, pad=0.08, label="ΔB/B0 (ppm)")
    hz = bar.ax.secondary_yaxis("left", functions=(lambda x: offset_hz(x, p.b0_T),
                                                lambda f: f / offset_hz(1.0, p.b0_T)))
    hz.set_ylabel(f"Δf at {p.b0_T:g} T (Hz)")
    return fig


def image_figure(a: Artefact) -> Figure:
    """The simulated gradient-echo magnitude (1 = the phantom without the sensor) on three
    slices, the sensor's outline (blue) and the artefact region, loss > 30 % (red)."""
    g, ig, p = a.scene.grid, a.image_grid, a.protocol
    s = a.summary()["gradient_echo"]
    fig = Figure(figsize=(13, 4.2), layout="constrained")
    axes = _panels(fig, f"{a.design.name} ({a.body_material}) in {a.scene.medium}: gradient echo "
                        f"TE {p.te_ms:g} ms at {p.b0_T:g} T, voxel {p.voxel_mm:g} mm; red: signal "
                        f"loss > {100 * SIGNAL_LOSS_THRESHOLD:.0f} %, reaching {s['extent_mm']:.1f} mm "
                        "from the surface")
    at = slice_points(a)
    for ax, (title, n, u, v) in zip(axes, _VIEWS):
        ax.imshow(_cut(a.magnitude, ig, n, at[n]).T, origin="lower", extent=_extent(ig, u, v),
                  cmap="gray", vmin=0.0, vmax=1.2, interpolation="nearest")
        ax.contour(ig.centres(u), ig.centres(v), _cut(a.artefact, ig, n, at[n]).T.astype(float),
                   levels=[0.5], colors="red", linewidths=0.9)
        _outline(ax, a, n, u, v, at[n], "tab:blue")
        ax.set(title=f"{title} ({_NAMES[n]} = {at[n]:.1f} mm)", xlabel=f"{_NAMES[u]} (mm)",
               ylabel=f"{_NAMES[v]} (mm)")
        ax.title.set_fontsize(9)
    return fig


def comparison_figure(artefacts: list[Artefact]) -> Figure:
    """The simulated gradient-echo images of several predictions side by side (one column
    each; x-y mid-plane above, y-z through the fiber below), artefact region in red."""
    fig = Figure(figsize=(4.2 * len(artefacts), 7.6), layout="constrained")
    p = artefacts[0].protocol
    fig.suptitle(f"gradient echo TE {p.te_ms:g} ms at {p.b0_T:g} T, voxel {p.voxel_mm:g} mm: "
                 f"red, signal loss > {100 * SIGNAL_LOSS_THRESHOLD:.0f} %", fontsize=10)
    axes = fig.subplots(2, len(artefacts), squeeze=False)
    for col, a in enumerate(artefacts):
        ig, at = a.image_grid, slice_points(a)
        extent = a.summary()["gradient_echo"]["extent_mm"]
        for row, (title, n, u, v) in enumerate((_VIEWS[0], _VIEWS[2])):
            ax = axes[row, col]
            ax.imshow(_cut(a.magnitude, ig, n, at[n]).T, origin="lower", extent=_extent(ig, u, v),
                      cmap="gray", vmin=0.0, vmax=1.2, interpolation="nearest")
            ax.contour(ig.centres(u), ig.centres(v), _cut(a.artefact, ig, n, at[n]).T.astype(float),
                       levels=[0.5], colors="red", linewidths=0.9)
            _outline(ax, a, n, u, v, at[n], "tab:blue")
            ax.set(xlabel=f"{_NAMES[u]} (mm)", ylabel=f"{_NAMES[v]} (mm)")
            ax.set_title(f"{a.body_material} in {a.scene.medium}: {extent:.1f} mm" if row == 0 else title,
                         fontsize=9)
    return fig
