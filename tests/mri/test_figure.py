"""The pair figure: a mm scale bar of a round length on the images when the spacing is known,
none without it, and row labels only when there are several rows."""

from __future__ import annotations

import numpy as np

from mri.figure import PairPanel, pair_figure


def _bars(fig):
    from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar

    return [artist for ax in fig.axes for artist in ax.artists if isinstance(artist, AnchoredSizeBar)]


def test_scale_bar_is_a_round_length_in_mm():
    image = np.random.default_rng(0).normal(100, 5, (256, 256))
    fig = pair_figure([PairPanel("pair", image, image + 1, (), pixel_spacing_mm=(0.9765625, 0.9765625))])
    bars = _bars(fig)
    assert len(bars) == 2  # a and b; none on the red-blue difference
    # a fifth of 250 mm is 50 mm: the bar is 50 mm = 51.2 px long
    label = bars[0].txt_label.get_children()[0].get_text()
    assert label == "50 mm"
    assert bars[0].size_bar.get_children()[0].get_width() == np.float64(50 / 0.9765625)
    assert fig.axes[0].get_ylabel() == ""


def test_no_scale_bar_without_spacing_and_rows_named_when_several():
    image = np.ones((64, 64))
    fig = pair_figure([PairPanel("reference vs x", image, image, ()), PairPanel("reference vs y", image, image, ())])
    assert _bars(fig) == []
    assert fig.axes[0].get_ylabel() == "reference vs x"
