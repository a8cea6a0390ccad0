"""Errors raised by :mod:`mri` for images and image pairs that cannot be used."""


class MriError(ValueError):
    """Base class: an image, pair, ROI or file the MRI tools cannot accept."""


class ImageLoadError(MriError):
    """A file or folder that holds no usable image (not an image, no pixels, NaN, ...)."""


class PairMismatchError(MriError):
    """Two images that cannot be compared (shape, spacing, orientation, protocol)."""


class RoiError(MriError):
    """A region of interest that is malformed, empty or outside the image."""


class MeasurementError(MriError):
    """A measure that is undefined for the data (e.g. zero noise between identical images)."""


class BoxOutsidePhantomError(RoiError):
    """Automatic boxes that leave the phantom; ``rois`` are all the boxes (to draw them) and
    ``fit`` the phantom found (:class:`mri.phantom.PhantomFit`)."""

    def __init__(self, message: str, rois=(), fit=None):
        super().__init__(message)
        self.rois = rois
        self.fit = fit
