"""Figure of image pairs like the thesis' Figures 57, 58 and 60: a, b and a - b with the ROIs drawn
(or, for one image, the image and its smoothed-subtraction noise image).

The figure is returned, not written: the caller saves it (atomically, at the CLI edge).

Display: a and b share one grey scale from 0 (or the lowest pixel, if negative) to the
brightest pixel of the two, so no pixel saturates (a window at a high percentile clips the
bright rim and the Gibbs ripples of a phantom to white). a - b is shown on a symmetric scale
of +-4 robust standard deviations (median absolute deviation) so that noise and artefacts are
both visible; pixels beyond it (the phantom's edge, see :mod:`mri.registration`) are clipped.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mri.roi import Roi

#: Colours of successive ROIs; a ROI keeps its colour in all panels.
ROI_COLOURS = ("tab:red", "tab:orange", "tab:green", "tab:cyan", "tab:purple", "tab:pink",
               "tab:olive", "tab:brown")


@dataclass(frozen=True, eq=False)
class PairPanel:
    """One row of the figure: a title, the 2-D slices a and b (None for one image), the ROIs
    drawn on them, the images' names and the pixel spacing (row, col; mm) of the scale bar
    (none when unknown)."""

    title: str
    a: np.ndarray
    b: np.ndarray | None
    rois: tuple[Roi, ...]
    a_name: str = "a"
    b_name: str | None = "b"
    pixel_spacing_mm: tuple[float, float] | None = None


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


def _images(panel: PairPanel):
    """(image, title, imshow style, colour-bar label) of each column of a row."""
    from mri.snr import SMOOTHING_KERNEL_PX, difference_percent, smoothed_noise_image

    shown = [panel.a] + ([] if panel.b is None else [panel.b])
    lo = min(0.0, min(float(x.min()) for x in shown))
    hi = max(float(x.max()) for x in shown)
    grey = dict(cmap="gray", vmin=lo, vmax=hi if hi > lo else lo + 1)
    if panel.b is None:
        diff = smoothed_noise_image(panel.a.astype(np.float64), SMOOTHING_KERNEL_PX)
        diff_title = f"{panel.a_name} - {SMOOTHING_KERNEL_PX} x {SMOOTHING_KERNEL_PX} mean\n(smoothed-subtraction noise)"
    else:
        diff = panel.a.astype(np.float64) - panel.b
        total = float(np.sum(panel.a))
        percent = f"\ndifference {difference_percent(panel.a, panel.b):.2f} %" if total > 0 else ""
        diff_title = f"{panel.a_name} - {panel.b_name}{percent}"
    mad = float(np.median(np.abs(diff - np.median(diff))))
    limit = 4 * 1.4826 * mad or float(np.max(np.abs(diff))) or 1.0
    columns = [(panel.a, panel.a_name, grey, None)]
    if panel.b is not None:
        columns.append((panel.b, panel.b_name, grey, "pixel value"))
    else:
        columns[0] = (panel.a, panel.a_name, grey, "pixel value")
    columns.append((diff, diff_title, dict(cmap="RdBu_r", vmin=-limit, vmax=limit), "pixel value difference"))
    return columns


def _scale_bar(ax, spacing_mm: tuple[float, float], cols: int) -> None:
    """A white bar of a round length (1, 2, 5 x 10^k mm, about a fifth of the width) in the
    lower left corner, labelled in mm."""
    from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar

    target = cols * spacing_mm[1] / 5
    step = 10 ** np.floor(np.log10(target))
    length = max(m * step for m in (1, 2, 5) if m * step <= target)
    ax.add_artist(AnchoredSizeBar(ax.transData, length / spacing_mm[1], f"{length:g} mm",
                                  "lower left", pad=0.4, color="white", frameon=False,
                                  size_vertical=max(1.0, 0.006 * cols), fontproperties={"size": 8}))


def pair_figure(panels: list[PairPanel]):
    """A matplotlib figure with one row (a, b, a - b; or a and its noise image) per panel."""
    from matplotlib.figure import Figure

    from geometry import style

    style.use()
    from matplotlib.lines import Line2D

    n_cols = max(2 if p.b is None else 3 for p in panels)
    fig = Figure(figsize=(4.2 * n_cols, 4.2 * len(panels) + 0.8), layout="constrained")
    axes = fig.subplots(len(panels), n_cols, squeeze=False)
    legend = {}
    for row, panel in zip(axes, panels):
        columns = _images(panel)
        for ax, (image, name, style, bar) in zip(row, columns):
            shown = ax.imshow(image, interpolation="nearest", **style)
            _draw_rois(ax, panel.rois)
            ax.set_title(name, fontsize=11)
            ax.set_xticks([])
            ax.set_yticks([])
            ax.set_xlim(-0.5 - 1, image.shape[1] - 0.5 + 1)
            ax.set_ylim(image.shape[0] - 0.5 + 1, -0.5 - 1)
            if bar:
                fig.colorbar(shown, ax=ax, shrink=0.8, label=bar)
            if panel.pixel_spacing_mm and style["cmap"] == "gray":  # white bar on the dark images
                _scale_bar(ax, panel.pixel_spacing_mm, image.shape[1])
        for ax in row[len(columns):]:
            ax.set_axis_off()
        if len(panels) > 1:  # rows named only when there are several (reference vs conditions)
            row[0].set_ylabel(panel.title, fontsize=11)
        for k, roi in enumerate(panel.rois):
            colour = ROI_COLOURS[k % len(ROI_COLOURS)]
            legend.setdefault((roi.label, colour), Line2D([], [], color=colour, label=roi.label))
    fig.legend(handles=list(legend.values()), loc="outside lower center",
               ncols=min(3, len(legend)), fontsize=10, frameon=False)
    return fig
