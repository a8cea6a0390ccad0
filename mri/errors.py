"""Errors raised by :mod:`mri` for images and image pairs that cannot be used."""


class MriError(ValueError):
    """Base class: an image, pair, ROI or file the MRI tools cannot accept."""
