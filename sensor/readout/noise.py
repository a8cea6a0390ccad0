"""Noise of the fiber-mirror readout and a sampler of noisy outputs (thesis Figure 61).

Sources (white, one-sided power spectral densities, integrated over a bandwidth B in Hz):

* shot noise of each photocurrent I: i^2 = 2 q I B;
* Johnson noise of each transimpedance resistor G (the amplifier's gain): i^2 = 4 k T B / G;
* source intensity fluctuation, relative intensity noise RIN (dB/Hz):
  (dP/P)^2 = 10^(RIN/10) B. It multiplies the signal and the reference alike.

Two readouts of the signal channel (``readout``):

* ``"direct"``: V = offset + G I_s; it carries the source fluctuation and drift;
* ``"ratio"``: the signal divided by the reference photodiode, rescaled by the nominal
  reference so that it reads like the direct output at nominal source power:
  V = offset + (V_s - offset) V_r0 / V_r. Source power cancels exactly, so RIN and drift
  vanish; the reference channel's own shot and Johnson noise enter instead, weighted by
  (V_s - offset) / V_r0 (first-order error propagation).

Samples at a sample rate f_s are taken behind an ideal anti-alias filter, so each carries
the noise of the bandwidth B = f_s / 2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.constants import e as Q_E
from scipy.constants import k as K_B

from sensor.errors import OpticsError
from sensor.readout.optics import (
    OpticsSetup,
    _finite,
    _require,
    reference_photocurrent_A,
    signal_photocurrent_A,
    voltage_slope,
)

READOUTS = ("direct", "ratio")


def _readout(readout: str) -> str:
    _require(readout in READOUTS, "readout", readout, f"one of {READOUTS}")
    return readout


def _positive(name: str, value) -> float:
    _require(_finite(value) and value > 0, name, value, "a finite number > 0")
    return float(value)


@dataclass(frozen=True)
class NoiseBudget:
    """RMS output noise, V, of each source over ``bandwidth_Hz`` and their quadrature sum.

    shot_V / johnson_V: signal channel; source_V: source intensity fluctuation (0 for the
    ratio readout); reference_V: the reference channel's shot + Johnson noise carried into
    the ratio (0 for the direct readout). Arrays follow the shape of the gap.
    """

    shot_V: np.ndarray
    johnson_V: np.ndarray
    source_V: np.ndarray
    reference_V: np.ndarray
    total_V: np.ndarray
    bandwidth_Hz: float
    readout: str


def relative_source_noise(setup: OpticsSetup, bandwidth_Hz: float) -> float:
    """RMS relative source power fluctuation over the bandwidth (dimensionless)."""
    return math.sqrt(10.0 ** (setup.source_rin_dB_per_Hz / 10.0)
                     * _positive("bandwidth_Hz", bandwidth_Hz))


def noise_budget(setup: OpticsSetup, bandwidth_Hz: float, gap_mm, model: str = "geometric",
                 readout: str = "ratio") -> NoiseBudget:
    """Noise contributions at the output for a gap (mm) and bandwidth (Hz), V RMS."""
    band = _positive("bandwidth_Hz", bandwidth_Hz)
    _readout(readout)
    i_s = signal_photocurrent_A(gap_mm, setup, model)
    g, g_r, temp = setup.gain_V_per_A, setup.reference_gain_V_per_A, setup.temperature_K
    shot = g * np.sqrt(2.0 * Q_E * i_s * band)
    johnson = np.full_like(i_s, math.sqrt(4.0 * K_B * temp * g * band))
    zero = np.zeros_like(i_s)
    if readout == "direct":
        source, reference = g * i_s * relative_source_noise(setup, band), zero
    else:
        i_r = reference_photocurrent_A(setup)
        sigma_ref = math.sqrt(g_r**2 * 2.0 * Q_E * i_r * band + 4.0 * K_B * temp * g_r * band)
        source, reference = zero, (g * i_s) / (g_r * i_r) * sigma_ref
    total = np.sqrt(shot**2 + johnson**2 + source**2 + reference**2)
    return NoiseBudget(shot, johnson, source, reference, total, band, readout)


def noise_rms_V(setup: OpticsSetup, bandwidth_Hz: float, gap_mm, model: str = "geometric",
                readout: str = "ratio") -> np.ndarray:
    """Total RMS output noise, V, over ``bandwidth_Hz`` at ``gap_mm``."""
    return noise_budget(setup, bandwidth_Hz, gap_mm, model, readout).total_V


def gap_resolution_mm(setup: OpticsSetup, bandwidth_Hz: float, gap_mm,
                      model: str = "geometric", readout: str = "ratio") -> np.ndarray:
    """Noise-equivalent gap change, mm RMS: noise_rms_V / |dV/dgap|."""
    noise = noise_rms_V(setup, bandwidth_Hz, gap_mm, model, readout)
    with np.errstate(divide="ignore"):
        return noise / np.abs(voltage_slope(gap_mm, setup, model))


def sample_output(gap_mm, setup: OpticsSetup, sample_rate_Hz: float,
                  rng: np.random.Generator, model: str = "geometric", readout: str = "ratio",
                  source_scale=1.0) -> np.ndarray:
    """Noisy output samples, V, one per element of ``gap_mm`` (a gap history, mm).

    ``source_scale`` (scalar or array broadcastable to the gaps, > 0) multiplies the source
    power: a slow drift on top of the white fluctuation. ``rng`` carries the random state,
    so one call per sample and one call per array give the same statistics.
    """
    rate = _positive("sample_rate_Hz", sample_rate_Hz)
    _readout(readout)
    if not isinstance(rng, np.random.Generator):
        raise OpticsError(f"rng = {rng!r}: must be a numpy.random.Generator")
    i_s0 = signal_photocurrent_A(gap_mm, setup, model)
    scale = np.broadcast_to(np.asarray(source_scale, dtype=float), i_s0.shape)
    bad = ~np.isfinite(scale) | (scale <= 0)
    if np.any(bad):
        raise OpticsError(f"source_scale = {scale[bad].flat[0]!r}: must be finite and > 0")
    band = rate / 2.0
    power = scale * (1.0 + relative_source_noise(setup, band) * rng.standard_normal(i_s0.shape))
    g, g_r, temp = setup.gain_V_per_A, setup.reference_gain_V_per_A, setup.temperature_K

    def detect(current: np.ndarray, gain: float) -> np.ndarray:
        var = 2.0 * Q_E * current * band + 4.0 * K_B * temp * band / gain
        return gain * (current + np.sqrt(var) * rng.standard_normal(current.shape))

    v_s = detect(i_s0 * power, g)
    if readout == "direct":
        return setup.offset_V + v_s
    i_r0 = reference_photocurrent_A(setup)
    v_r = detect(i_r0 * power, g_r)
    return setup.offset_V + v_s * (g_r * i_r0) / v_r
