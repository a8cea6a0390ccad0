"""The MRI artefact of a sensor before it is cut: the B0 field its body, fiber and mirror
disturb (dipole kernel by FFT), the spin-echo shift and the gradient-echo signal loss.

A small lazy facade: ``import sensor.artefact`` loads nothing heavy.

>>> import geometry, sensor.artefact as art
>>> a = art.predict(geometry.preset("sample-b"), art.Protocol(b0_T=3.0, te_ms=10.0))  # doctest: +SKIP
>>> a.summary()["gradient_echo"]["extent_mm"]  # doctest: +SKIP
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "susceptibility": ["MEDIA", "SUSCEPTIBILITY_PPM", "chi_ppm"],
        "field": ["b0_unit", "cylinder_offset_ppm", "field_offset_ppm", "offset_hz", "sphere_offset_ppm"],
        "voxels": ["Grid", "grid_around", "occupancy"],
        "scene": ["Scene", "sensor_scene"],
        "prediction": ["Artefact", "Protocol", "predict"],
        "plots": ["comparison_figure", "field_figure", "image_figure"],
    },
)
