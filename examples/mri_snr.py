"""SNR of a real repeated MR acquisition (Siemens Aera 1.5 T, hazen test data, Apache-2.0).

Run from the repository root:  .venv/bin/python examples/mri_snr.py [figure.png]
The same numbers come from:    dacm snr tests/data/mri/siemens_aera_pair/tra_250_2meas_{1,2}.IMA
"""

import sys
from pathlib import Path

from geometry.atomic import save_figure
from mri.figure import PairPanel, pair_figure
from mri.io import load_image
from mri.pair import check_pair
from mri.roi import parse_roi, resolve_roi
from mri.snr import measure_arrays

PAIR = Path(__file__).resolve().parents[1] / "tests" / "data" / "mri" / "siemens_aera_pair"

a = load_image(PAIR / "tra_250_2meas_1.IMA")
b = load_image(PAIR / "tra_250_2meas_2.IMA")
print("warnings:", check_pair(a, b) or "none")
print(f"{a.scanner}, {a.shape[1]} x {a.shape[2]} px of {a.pixel_spacing_mm[0]:.3f} mm, "
      f"TR {a.acquisition['repetition_time_ms']:g} ms, TE {a.acquisition['echo_time_ms']:g} ms")

# The thesis' method over the whole image, NEMA over five boxes and over the eroded phantom.
specs = {"thesis": (parse_roi("whole"), parse_roi("phantom")), "nema": (parse_roi("nema5"), parse_roi("phantom"))}
result = measure_arrays(a.pixels, b.pixels, a.pixel_spacing_mm, specs)
for method in result.slices[0].methods:
    for roi in method.rois:
        print(f"{method.method:6} {roi.roi:36} signal {roi.signal:8.1f}  noise {roi.noise:6.2f}  SNR {roi.snr:7.1f}")
print(f"difference sum|a-b| / sum a = {result.difference_percent:.3f} %")

out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("mri_snr.png")
rois = resolve_roi(parse_roi("nema5"), a.pixels[0].astype(float), a.pixel_spacing_mm)
figure = pair_figure([PairPanel("Siemens Aera pair", a.pixels[0], b.pixels[0], rois, "image 1", "image 2",
                                a.pixel_spacing_mm)])
save_figure(figure, out)
print(f"figure: {out}")
