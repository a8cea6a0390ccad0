"""MR images in, SNR out: load images and pairs, measure them, and the errors.

A small lazy facade (``import mri`` loads nothing heavy; numpy, scipy and pydicom come with the
first call). The modules hold the rest: :mod:`mri.io` (loaders), :mod:`mri.snr` (the methods
on arrays), :mod:`mri.roi`, :mod:`mri.phantom`, :mod:`mri.quality` (the warnings),
:mod:`mri.normalise`, :mod:`mri.figure`.

>>> import mri
>>> pair = mri.measure_pair("tests/data/mri/siemens_aera_pair/tra_250_2meas_1.IMA",
...                         "tests/data/mri/siemens_aera_pair/tra_250_2meas_2.IMA")  # doctest: +SKIP
>>> round(pair.result.summary("nema").snr, 1), [w.code for w in pair.warnings]  # doctest: +SKIP
(220.0, [])
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "io": ["load_image"],
        "image": ["MriImage"],
        "study": ["MeasuredPair", "SnrOptions", "load_pair", "measure_pair"],
        "quality": ["QualityWarning"],
        "errors": ["BoxOutsidePhantomError", "ImageLoadError", "MeasurementError", "MriError",
                   "PairMismatchError", "RoiError"],
    },
)
