"""An artefact prediction as an xarray dataset (``dacm artefact`` writes it as NetCDF-4):
the field offset map in ppm and in Hz, the susceptibility and the sensor's fraction on the
field grid, the simulated gradient-echo magnitude and the artefact mask on the image grid.
Coordinates in mm, in the sensor's frame; the summary's numbers are its attributes."""

from __future__ import annotations

import json

import numpy as np
import xarray as xr

from sensor.artefact.field import offset_hz
from sensor.artefact.prediction import Artefact


def artefact_dataset(a: Artefact) -> xr.Dataset:
    """The maps of ``a`` with units and descriptions."""
    g, ig = a.scene.grid, a.image_grid
    fine, coarse = ("x", "y", "z"), ("x_image", "y_image", "z_image")
    coords = {**{n: (n, g.centres(i), {"units": "mm"}) for i, n in enumerate(fine)},
              **{n: (n, ig.centres(i), {"units": "mm"}) for i, n in enumerate(coarse)}}
    ds = xr.Dataset(
        {"field_ppm": (fine, a.field_ppm, {"units": "ppm", "description": "ΔB/B0 along B0, Lorentz-corrected"}),
         "field_hz": (fine, offset_hz(a.field_ppm, a.protocol.b0_T).astype(np.float32),
                      {"units": "Hz", "description": f"resonance offset at {a.protocol.b0_T:g} T"}),
         "chi_ppm": (fine, a.scene.chi_ppm, {"units": "ppm", "description": "volume susceptibility (SI)"}),
         "solid": (fine, a.scene.solid, {"units": "1", "description": "fraction of the voxel that is sensor"}),
         "magnitude": (coarse, a.magnitude, {"units": "1", "description":
                                             "simulated gradient-echo magnitude; 1 without the sensor"}),
         "artefact": (coarse, a.artefact.astype(np.int8), {"units": "1", "description":
                                                           "signal loss above the threshold"})},
        coords=coords,
        attrs={"summary": json.dumps(a.summary())},
    )
    return ds


def write_dataset(ds: xr.Dataset, path) -> None:
    """Write NetCDF-4 (h5netcdf), every variable compressed."""
    encoding = {name: {"zlib": True, "complevel": 1} for name in ds.data_vars}
    ds.to_netcdf(path, engine="h5netcdf", encoding=encoding)
