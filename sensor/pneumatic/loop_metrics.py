"""Metrics of one closed-loop run and the rule that names it settled, limit_cycle or unsettled
(DESIGN section 15).

:func:`metrics` gives the figures the thesis reports: the force-control MSE and the
pressure-estimation MSE of eq 44 over the steady window (the last whole cycles covering two
seconds; the two seconds from a step, thesis section 5.4.2), and the run's status by
:func:`classify`:

* ``limit_cycle``: over the last :data:`LC_WINDOW_S` seconds (at least :data:`LC_CYCLES` whole
  reference cycles) the force error, less its part periodic with the reference (the
  cycle-synchronous mean, which averages an oscillation not locked to the reference out; a step
  run: its mean), is a sustained oscillation at a frequency that is no harmonic of the reference
  (farther than half the window's resolution, 1/(2 T), from every one): its
  fundamental (least-squares sine at the periodogram peak) has an amplitude of at least
  :data:`LC_MIN_AMPLITUDE` of the reference amplitude, it and its second and third harmonics hold
  at least :data:`LC_CONCENTRATION` of that residual's power, and its amplitude in the two halves
  of the window agrees within :data:`LC_STEADY`.  Its frequency (Hz) and amplitude (N) are a
  result, reported beside the MSEs.
* ``settled`` (not a limit cycle): periodic references - the per-cycle MSE of the force, of the
  estimate's pressure and (line-model controller) of the virtual input and its line model's
  pressure, averaged over the last :data:`SETTLE_CYCLES` cycles and over the cycles before, agree
  within :data:`SETTLE_CHANGE` of the larger, or both lie below a floor near the sensors' noise
  (no standard-error escape); a step - the force error's RMS over the 0.2 s before the step and
  over the last 0.2 s of its window is below 5 % of the step.  A run that fails this only on
  the scatter its sensors' noise drives (the closed loop's narrow-band response to white
  sensor noise makes 5-cycle block means differ by 10-30 % in a stationary run; measured) is
  settled when its noise-free twin - the same setup with ideal sensors
  (:attr:`~sensor.pneumatic.experiment.Setup.sensor_noise` off) - passes the same rule and is
  no limit cycle: the deterministic response has converged, and the run reports
  ``settled_by`` ``noise_free_twin`` with ``noise_block_change``, its own largest block change.
* ``unsettled``: neither.
"""
from __future__ import annotations

import math

import numpy as np
import xarray as xr

from sensor.errors import SensorInputError, SolverError
from sensor.pneumatic.controllers import Reference

MSE_WINDOW_S = 2.0       # thesis 5.4.2: "mean of error squares obtained in a 2-second time interval"
SETTLE_CYCLES = 5        # cycles per block of the settling rule
SETTLE_CHANGE = 0.10     # relative bound between the two blocks' mean per-cycle MSEs
SETTLE_FLOOR = {"N2": 1e-3, "kPa2": 0.05}   # ~ the sensors' noise: (0.02 N)^2 x 2.5, (0.2 kPa)^2 + 25 %
STEP_SETTLE_FRACTION = 0.05
STEP_SETTLE_S = 0.2
LC_WINDOW_S = 10.0          # the end of the run searched for a limit cycle (at least LC_CYCLES whole cycles)
LC_CYCLES = 10              # ... so that the cycle-synchronous mean averages an unlocked oscillation out
LC_MIN_AMPLITUDE = 0.05     # fundamental amplitude / reference amplitude (1.2 N at 24 N)
LC_CONCENTRATION = 0.5      # power of the fundamental and 2 harmonics / power of the non-synchronous error
LC_STEADY = 0.25            # |amplitude, second half / first half - 1|
STATUSES = ("settled", "limit_cycle", "unsettled")
SETTLING_RULE = (f"limit_cycle: over the last {LC_WINDOW_S:g} s (at least {LC_CYCLES} cycles) the force error "
                 f"less its cycle-synchronous mean oscillates at a frequency that is no reference harmonic, fundamental "
                 f">= {LC_MIN_AMPLITUDE:.0%} of the reference amplitude, holding >= {LC_CONCENTRATION:.0%} of that error's power with 2 harmonics, "
                 f"its amplitude steady within {LC_STEADY:.0%} between the halves; otherwise settled - periodic: the "
                 f"per-cycle MSE of the force, the estimate's pressure and (line model) the virtual input and its "
                 f"pressure, averaged over the last {SETTLE_CYCLES} cycles and the {SETTLE_CYCLES} before, agree "
                 f"within {SETTLE_CHANGE:.0%} (or both < 1e-3 N^2 / 0.05 kPa^2, the sensors' noise); step: force-error "
                 f"RMS < {STEP_SETTLE_FRACTION:.0%} of the step over the {STEP_SETTLE_S:g} s before it and the last "
                 f"{STEP_SETTLE_S:g} s of its window; a run failing only this is settled when the same setup with "
                 "noise-free sensors passes it and is no limit cycle (its own largest block change reported); "
                 "else unsettled")


def window(ds: xr.Dataset, reference: Reference) -> slice:
    """The steady window: the last whole cycles covering MSE_WINDOW_S of a periodic run, or
    MSE_WINDOW_S from a step."""
    end = float(ds.time[-1])
    if reference.kind == "step":
        return slice(reference.step_s, min(end, reference.step_s + MSE_WINDOW_S))
    period = 1.0 / reference.frequency_Hz
    span = max(period, math.ceil(MSE_WINDOW_S / period - 1e-9) * period)
    return slice(end - span, end)


def squared_errors(ds: xr.Dataset) -> dict[str, np.ndarray]:
    """Per-sample squared errors whose means are the reported MSEs: force (N^2), eq 44's
    1/2 (P~1^2 + P~2^2) of the estimate, the valve ports and the line model (kPa^2), and the
    virtual input's (N^2).  NaN at the last sample, which has no controller row."""
    def pressure(p1, p2):
        return 0.5 * ((p1 - ds.pressure_chamber.sel(side=1).values) ** 2
                      + (p2 - ds.pressure_chamber.sel(side=2).values) ** 2) / 1e6
    out = {"force_mse_N2": (ds.desired_force_N.values - ds.environment_force.values) ** 2,
           "pressure_mse_kPa2": pressure(ds.estimated_pressure_1_Pa.values, ds.estimated_pressure_2_Pa.values),
           "valve_pressure_mse_kPa2": pressure(ds.pressure_valve.sel(side=1).values, ds.pressure_valve.sel(side=2).values)}
    if "virtual_input_N" in ds:
        out["virtual_input_mse_N2"] = (ds.virtual_input_desired_N.values - ds.virtual_input_N.values) ** 2
        out["line_model_pressure_mse_kPa2"] = pressure(ds.line_model_pressure_1_Pa.values,
                                                       ds.line_model_pressure_2_Pa.values)
    return out


def per_cycle(ds: xr.Dataset, frequency_Hz: float, errors: dict | None = None) -> dict:
    """Each MSE of :func:`squared_errors` over each whole cycle of a periodic reference
    (``cycle_start_s`` and one list per quantity; Figure 27)."""
    errors = squared_errors(ds) if errors is None else errors
    t = ds.time.values
    period = 1.0 / frequency_Hz
    n = int((t[-1] + 1e-9) // period)
    edges = np.searchsorted(t, np.arange(n + 1) * period - 1e-9)
    out = {"cycle_start_s": [i * period for i in range(n)]}
    for key, sq in errors.items():
        out[key] = [float(np.nanmean(sq[edges[i]:edges[i + 1]])) for i in range(n)]
    return out


def _sine_fit(t: np.ndarray, r: np.ndarray, f: float) -> float:
    """Amplitude of the least-squares sine (with its cosine) of frequency f (Hz) in r."""
    w = 2 * math.pi * f * t
    basis = np.column_stack([np.cos(w), np.sin(w)])
    coef, *_ = np.linalg.lstsq(basis, r, rcond=None)
    return float(np.hypot(*coef))


def nonsynchronous_error(t: np.ndarray, e: np.ndarray, frequency_Hz: float | None) -> np.ndarray:
    """e less its part periodic with the reference: the mean over whole cycles at each phase
    (cycles of unequal sample count are cut to the shortest); with no frequency, its mean."""
    if not frequency_Hz:
        return e - e.mean()
    edges = np.searchsorted(t, t[0] + np.arange(int((t[-1] - t[0] + 1e-9) * frequency_Hz) + 1) / frequency_Hz - 1e-9)
    n = int(np.min(np.diff(edges)))
    cycles = np.stack([e[a:a + n] for a in edges[:-1]])
    r = e.copy()
    for a in edges[:-1]:
        r[a:a + n] -= cycles.mean(axis=0)
    return r[:edges[-2] + n]


def limit_cycle(t: np.ndarray, e: np.ndarray, frequency_Hz: float | None, amplitude_N: float) -> dict:
    """The limit-cycle test of the module docstring on the force error e(t) (N) of the analysed
    window; ``limit_cycle`` with ``hz`` and ``amplitude_N`` (the fundamental's), and the evidence."""
    r = nonsynchronous_error(t, e, frequency_Hz)
    t = t[:r.size]
    dt = float(np.median(np.diff(t)))
    spec = np.abs(np.fft.rfft(r * np.hanning(r.size), 8 * r.size))
    freqs = np.fft.rfftfreq(8 * r.size, dt)
    lo = 2.0 / (t[-1] - t[0])                    # at least two periods in the window
    spec[freqs < lo] = 0.0
    peak = float(freqs[int(np.argmax(spec))])
    fine = np.linspace(peak - 0.5 * lo, peak + 0.5 * lo, 41)
    hz = float(fine[int(np.argmax([_sine_fit(t, r, f) for f in fine]))])
    amp = _sine_fit(t, r, hz)
    power = float(np.mean(r * r))
    harmonics = sum(0.5 * _sine_fit(t, r, k * hz) ** 2 for k in (1, 2, 3)) if hz > 0 else 0.0
    half = r.size // 2
    halves = [_sine_fit(t[:half], r[:half], hz), _sine_fit(t[half:], r[half:], hz)]
    steady = halves[0] > 0 and abs(halves[1] / halves[0] - 1) <= LC_STEADY
    # within half the window's frequency resolution (1/(2 T)) of a reference harmonic the cycle-synchronous mean
    # cannot tell a limit cycle from tracking error: not named a limit cycle
    harmonic = bool(frequency_Hz) and abs(hz - round(hz / frequency_Hz) * frequency_Hz) <= 0.25 * lo
    found = (hz > 0 and not harmonic and amp >= LC_MIN_AMPLITUDE * abs(amplitude_N)
             and harmonics >= LC_CONCENTRATION * power and steady)
    return {"limit_cycle": bool(found), "hz": hz, "amplitude_N": amp,
            "concentration": harmonics / power if power > 0 else 0.0, "halves_N": halves}


def _settling(ds: xr.Dataset, reference: Reference, errors: dict) -> dict:
    """The settled rule of the module docstring (without the limit-cycle test)."""
    if reference.kind == "step":
        t = ds.time.values
        e2 = errors["force_mse_N2"]
        before = (t >= reference.step_s - STEP_SETTLE_S) & (t < reference.step_s)
        end = min(float(t[-1]), reference.step_s + MSE_WINDOW_S)
        after = (t > end - STEP_SETTLE_S) & (t <= end)
        rms = [float(np.sqrt(np.nanmean(e2[m]))) if m.any() else math.nan for m in (before, after)]
        limit = STEP_SETTLE_FRACTION * abs(reference.amplitude_N)
        return {"settled": bool(all(r < limit for r in rms)), "step_rms_error_N": rms, "limit_N": limit}
    cyc = per_cycle(ds, reference.frequency_Hz, errors)
    n = SETTLE_CYCLES
    last = {k: v[-2 * n:] for k, v in cyc.items() if k not in ("cycle_start_s", "valve_pressure_mse_kPa2")}
    ok = len(cyc["cycle_start_s"]) >= 2 * n
    change = 0.0
    for key, vals in last.items() if ok else ():
        before, after = float(np.mean(vals[:n])), float(np.mean(vals[n:]))
        floor = SETTLE_FLOOR["kPa2" if key.endswith("kPa2") else "N2"]
        if max(before, after) > floor:
            change = max(change, abs(after - before) / max(before, after))
        ok = ok and (abs(after - before) <= SETTLE_CHANGE * max(before, after) or max(before, after) <= floor)
    return {"settled": bool(ok), "last_cycles": last, "block_change": change}


def _limit_cycle_test(ds: xr.Dataset, reference: Reference) -> dict:
    """:func:`limit_cycle` on the run's force error over the end of the run the module docstring
    names (``limit_cycle`` False when the run is too short for it)."""
    t = ds.time.values
    e = ds.desired_force_N.values - ds.environment_force.values
    if reference.kind == "step":
        start = max(float(t[-1]) - LC_WINDOW_S, reference.step_s + MSE_WINDOW_S)
        freq = None
    else:
        freq = reference.frequency_Hz
        cycles = max(LC_CYCLES, math.ceil(LC_WINDOW_S * freq - 1e-9))
        whole = math.floor((float(t[-1]) - float(t[0])) * freq + 1e-9)   # whole cycles in the run
        start = float(t[-1]) - min(cycles, whole) / freq
    sel = (t >= start - 1e-9) & np.isfinite(e)
    if np.count_nonzero(sel) >= 64 and (freq is None or t[-1] - start >= 2 / freq - 1e-9):
        return limit_cycle(t[sel], e[sel], freq, reference.amplitude_N)
    return {"limit_cycle": False}


def classify(ds: xr.Dataset, reference: Reference, errors: dict | None = None,
             twin: xr.Dataset | None = None) -> dict:
    """The run's ``status`` (settled, limit_cycle or unsettled; module docstring), the booleans
    ``settled`` and ``limit_cycle``, ``limit_cycle_hz`` and ``limit_cycle_amplitude_N`` when it is
    one, ``settled_by`` (``run`` or ``noise_free_twin``: ``twin`` is the same setup's run with
    noise-free sensors, consulted only when the run itself fails the settled rule) with
    ``noise_block_change`` when the twin decided, and the evidence (``last_cycles`` or the step's
    RMS errors, the limit-cycle test, the twin's)."""
    errors = squared_errors(ds) if errors is None else errors
    lc = _limit_cycle_test(ds, reference)
    st = _settling(ds, reference, errors)
    evidence = {**{k: v for k, v in st.items() if k != "settled"}, "limit_cycle_test": lc}
    settled_by = "run" if st["settled"] else None
    if not (lc["limit_cycle"] or st["settled"]) and twin is not None:
        tst, tlc = _settling(twin, reference, squared_errors(twin)), _limit_cycle_test(twin, reference)
        evidence["noise_free_twin"] = {"settled": tst["settled"], "block_change": tst.get("block_change"),
                                       "limit_cycle": tlc["limit_cycle"]}
        if tst["settled"] and not tlc["limit_cycle"]:
            settled_by = "noise_free_twin"
    status = "limit_cycle" if lc["limit_cycle"] else ("settled" if settled_by else "unsettled")
    out = {"status": status, "settled": status == "settled", "limit_cycle": status == "limit_cycle"}
    if out["limit_cycle"]:
        out["limit_cycle_hz"] = lc["hz"]
        out["limit_cycle_amplitude_N"] = lc["amplitude_N"]
    if out["settled"]:
        out["settled_by"] = settled_by
        if settled_by == "noise_free_twin":
            out["noise_block_change"] = st.get("block_change")
    out["evidence"] = evidence
    return out


def status_text(row: dict) -> str:
    """A run's status for a table: yes, 'yes by its noise-free twin (blocks 13 % apart)',
    'limit cycle 3.1 Hz, 50 N' or **no**."""
    if row.get("limit_cycle"):
        return f"limit cycle {row['limit_cycle_hz']:.3g} Hz, {row['limit_cycle_amplitude_N']:.3g} N"
    if row.get("settled") and row.get("settled_by") == "noise_free_twin":
        return f"yes by its noise-free twin (blocks {100 * (row.get('noise_block_change') or 0):.0f} % apart)"
    return "yes" if row.get("settled") else "**no**"


def metrics(ds: xr.Dataset, reference: Reference, twin: xr.Dataset | None = None) -> dict:
    """Force-control MSE (N^2) and eq 44 pressure-estimation MSE in kPa^2 (estimate and valve
    ports; for the line-model controller also MSE_2 and its line model's pressure MSE) over the
    steady window, with the status of :func:`classify` (``settled``, ``limit_cycle``, ...) and
    its evidence under ``settling``; ``twin``: the noise-free twin of :func:`classify`."""
    sl = window(ds, reference)
    t = ds.time.values
    inside = (t >= sl.start - 1e-9) & (t <= sl.stop + 1e-9)
    errors = squared_errors(ds)
    if np.count_nonzero(inside & np.isfinite(errors["force_mse_N2"])) < 2:
        raise SensorInputError(f"duration {float(t[-1]):.4g} s: too short for the MSE window "
                               f"(a step at {reference.step_s:g} s needs a longer run)")
    out = {key: float(np.nanmean(sq[inside])) for key, sq in errors.items()}
    for key, value in out.items():
        if not math.isfinite(value):
            raise SolverError(f"loop metrics: {key} = {value!r} over the steady window is not finite (the run "
                              "or the observer overflowed)")
    out["window_s"] = [float(t[inside][0]), float(t[inside][-1])]
    cl = classify(ds, reference, errors, twin)
    out.update({k: v for k, v in cl.items() if k != "evidence"})
    out["settling"] = cl["evidence"]
    return out
