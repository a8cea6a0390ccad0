"""Figure of image pairs like the thesis' Figures 57, 58 and 60: a, b and a - b with the ROIs drawn.

The figure is returned, not written: the caller saves it (atomically, at the CLI edge).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mri.roi import Roi

#: Colours of successive ROIs; a ROI keeps its colour in all three panels.
ROI_COLOURS = ("tab:red", "tab:orange", "tab:green", "tab:cyan", "tab:purple", "tab:pink")


@dataclass(frozen=True, eq=False)
class PairPanel:
    """One row of the figure: a title, the 2-D slices a and b, the ROIs drawn on them and the
    thesis' difference (percent) shown over a - b."""

    title: str
    a: np.ndarray
    b: np.ndarray
    rois: tuple[Roi, ...]
    difference_percent: float
    a_name: str = "a"
    b_name: str = "b"


def _draw_rois(ax, rois: tuple[Roi, ...]) -> None:
    """Outline each ROI; the mask is padded so that a ROI touching the border (``whole``) shows."""
    for k, roi in enumerate(rois):
        rows, cols = roi.mask.shape
        ax.contour(
            np.arange(-1, cols + 1),
            np.arange(-1, rows + 1),
            np.pad(roi.mask, 1).astype(float),
            levels=[0.5],
            colors=ROI_COLOURS[k % len(ROI_COLOURS)],
            linewidths=1.2,
        )


def pair_figure(panels: list[PairPanel]):
    """A matplotlib figure with one row (a, b, a - b) per panel; a and b share one grey scale.

    The difference is shown on a symmetric scale of +-4 robust standard deviations (median
    absolute deviation) so that noise and artefacts are both visible.
    """
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    fig = Figure(figsize=(12, 4.2 * len(panels) + 0.6), layout="constrained")
    axes = fig.subplots(len(panels), 3, squeeze=False)
    legend = {}
    for row, panel in zip(axes, panels):
        diff = panel.a - panel.b
        vmax = float(np.percentile(np.concatenate([panel.a.ravel(), panel.b.ravel()]), 99.5))
        mad = float(np.median(np.abs(diff - np.median(diff))))
        limit = 4 * 1.4826 * mad or float(np.max(np.abs(diff))) or 1.0
        images = (
            (panel.a, f"{panel.a_name}", dict(cmap="gray", vmin=0, vmax=vmax)),
            (panel.b, f"{panel.b_name}", dict(cmap="gray", vmin=0, vmax=vmax)),
            (diff, f"{panel.a_name} - {panel.b_name}\ndifference {panel.difference_percent:.2f} %",
             dict(cmap="RdBu_r", vmin=-limit, vmax=limit)),
        )
        for ax, (image, name, style) in zip(row, images):
            shown = ax.imshow(image, interpolation="nearest", **style)
            _draw_rois(ax, panel.rois)
            ax.set_title(name, fontsize=9)
            ax.set_xticks([])
            ax.set_yticks([])
            ax.set_xlim(-0.5 - 1, image.shape[1] - 0.5 + 1)
            ax.set_ylim(image.shape[0] - 0.5 + 1, -0.5 - 1)
        fig.colorbar(shown, ax=row[2], shrink=0.8, label="pixel value difference")
        row[0].set_ylabel(panel.title, fontsize=9)
        for k, roi in enumerate(panel.rois):
            colour = ROI_COLOURS[k % len(ROI_COLOURS)]
            legend.setdefault((roi.label, colour), Line2D([], [], color=colour, label=roi.label))
    fig.legend(handles=list(legend.values()), loc="outside lower center",
               ncols=min(3, len(legend)), fontsize=8, frameon=False)
    return fig
