"""Normalised SNR (McCann et al. 2013, as hazen and the MATLAB scripts compute it): the SNR
an acquisition would have with a 1 cm^3 voxel, 1 s of sampling and a 30 kHz half-bandwidth,
so that scanners and protocols can be compared.

    SNR_norm = SNR x sqrt(BW_px N_read / 2 / 30 kHz) / (V_voxel[cm^3] sqrt(NSA N_pe TR[s]))

SNR grows with the voxel volume V and with the square root of the time spent sampling
(NSA averages x N_pe phase-encoding steps x TR) and falls with the square root of the receiver
bandwidth (BW_px Hz/pixel x N_read readout samples), since white noise power is proportional
to the bandwidth. The inputs come from the DICOM header (PixelSpacing, SliceThickness,
PixelBandwidth, AcquisitionMatrix, NumberOfPhaseEncodingSteps, NumberOfAverages,
RepetitionTime; in enhanced DICOM the same from the per-frame and shared functional groups:
pixel measures, MR timing, MR averages, MR imaging modifier, and the acquisition matrix of
the MR FOV/Geometry sequence) and can be overridden (a measured slice width, a NIfTI without a header).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

from mri.errors import MriError
from mri.image import MriImage

#: Reference half-bandwidth of the normalisation (Hz).
REFERENCE_HALF_BANDWIDTH_HZ = 30_000.0


@dataclass(frozen=True)
class NormalisationInputs:
    """Acquisition quantities of the normalisation, each positive and finite: voxel size
    (mm), pixel bandwidth (Hz/pixel), readout samples and phase-encoding steps (counts),
    averages (NSA) and repetition time (ms)."""

    pixel_row_mm: float
    pixel_col_mm: float
    slice_thickness_mm: float
    pixel_bandwidth_hz: float
    readout_samples: float
    phase_steps: float
    averages: float
    repetition_time_ms: float

    def __post_init__(self):
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not (
                math.isfinite(value) and value > 0
            ):
                raise MriError(f"{f.name} = {value!r}: must be a positive finite number")


FIELDS = tuple(f.name for f in fields(NormalisationInputs))


def _matrix(image: MriImage) -> tuple[float | None, float | None]:
    """(readout samples, phase steps): an enhanced file's MR FOV/Geometry sequence
    (MRAcquisitionFrequencyEncodingSteps, MRAcquisitionPhaseEncodingStepsInPlane), else
    AcquisitionMatrix "freq rows\\freq cols\\phase rows\\phase cols" (one of each pair is 0)
    and NumberOfPhaseEncodingSteps."""
    readout = phase = None
    text = image.acquisition.get("acquisition_matrix")
    if isinstance(text, str):
        try:
            values = [float(v) for v in text.split("\\")]
        except ValueError:
            values = []
        if len(values) == 4:
            readout = max(values[0], values[1]) or None
            phase = max(values[2], values[3]) or None
    steps, frequency = image.acquisition.get("phase_steps"), image.acquisition.get("frequency_steps")
    readout = frequency if isinstance(frequency, float) and frequency > 0 else readout
    return readout, steps if isinstance(steps, float) and steps > 0 else phase


def header_values(image: MriImage) -> dict[str, float]:
    """The normalisation inputs the image's header holds (absent ones left out)."""
    readout, phase = _matrix(image)
    spacing = image.pixel_spacing_mm or (None, None)
    found = {
        "pixel_row_mm": spacing[0], "pixel_col_mm": spacing[1],
        "slice_thickness_mm": image.slice_thickness_mm,
        "pixel_bandwidth_hz": image.acquisition.get("pixel_bandwidth_hz"),
        "readout_samples": readout, "phase_steps": phase,
        "averages": image.acquisition.get("averages"),
        "repetition_time_ms": image.acquisition.get("repetition_time_ms"),
    }
    return {k: float(v) for k, v in found.items() if isinstance(v, (int, float)) and v}


def normalisation_inputs(image: MriImage, overrides: dict[str, float] | None = None
                         ) -> tuple[NormalisationInputs | None, tuple[str, ...]]:
    """The inputs from the header with ``overrides`` applied, or None and the missing fields."""
    overrides = overrides or {}
    unknown = sorted(set(overrides) - set(FIELDS))
    if unknown:
        raise MriError(f"normalisation field {unknown[0]!r} unknown; use one of {', '.join(FIELDS)}")
    for key, value in overrides.items():
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not (math.isfinite(value) and value > 0):
            raise MriError(f"{key} = {value!r}: must be a positive finite number")
    values = {**header_values(image), **overrides}
    missing = tuple(f for f in FIELDS if f not in values)
    if missing:
        return None, missing
    return NormalisationInputs(**values), ()


def normalisation_factor(inputs: NormalisationInputs) -> float:
    """The factor SNR_norm / SNR of the module's formula."""
    voxel_cm3 = inputs.pixel_row_mm * inputs.pixel_col_mm * inputs.slice_thickness_mm / 1000.0
    half_bandwidth = inputs.pixel_bandwidth_hz * inputs.readout_samples / 2
    time_s = inputs.averages * inputs.phase_steps * inputs.repetition_time_ms / 1000.0
    return math.sqrt(half_bandwidth / REFERENCE_HALF_BANDWIDTH_HZ) / (voxel_cm3 * math.sqrt(time_s))
