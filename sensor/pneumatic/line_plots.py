"""Figures of the line analysis (:mod:`sensor.pneumatic.line_response`) as matplotlib Figures.

Both functions take the plain-data result of :func:`~sensor.pneumatic.line_response.analyse`
and return a :class:`matplotlib.figure.Figure` (no backend is set; write it with
:func:`geometry.atomic.save_figure`).
"""
from __future__ import annotations

from matplotlib.figure import Figure

from geometry import style

style.use()

MODEL_COLOURS = {"dead-volume": "tab:orange", "richer-hurmuzlu": "tab:purple", "two-volume": "tab:green",
                 "preliminary": "tab:brown", "distributed": "tab:red"}


def case_title(inputs: dict, cm3: str = "cm$^3$") -> str:
    """One-line description of the rig: length, bore, volume, pressure."""
    return (f"L = {inputs['length_m']:g} m, D = {inputs['bore_m'] * 1e3:g} mm, "
            f"V = {inputs['volume_m3'] * 1e6:g} {cm3}, P = {inputs['pressure_Pa'] / 1e5:g} bar abs")


def frequency_figure(result: dict) -> Figure:
    """|p_end / p_in| and phase of every model against Bergh-Tijdeman (dashed), its first
    resonance dotted."""
    fig = Figure(figsize=(6.4, 5.6))
    ax_a, ax_p = fig.subplots(2, 1, sharex=True)
    ref = result["reference"]
    ax_a.plot(ref["frequency_hz"], ref["amplitude_ratio"], "k--", lw=2.2, label="Bergh-Tijdeman")
    ax_p.plot(ref["frequency_hz"], ref["phase_deg"], "k--", lw=2.2)
    for name, m in result["models"].items():
        ax_a.plot(m["frequency_hz"], m["amplitude_ratio"], color=MODEL_COLOURS[name], lw=1.3, label=name)
        ax_p.plot(m["frequency_hz"], m["phase_deg"], color=MODEL_COLOURS[name], lw=1.3)
    if ref["first_resonance_hz"] is not None:
        for ax in (ax_a, ax_p):
            ax.axvline(ref["first_resonance_hz"], color="0.4", ls=":", lw=1.2,
                       label=f"first resonance, Bergh-Tijdeman ({ref['first_resonance_hz']:.3g} Hz)")
    ax_a.set(xscale="log", yscale="log", ylabel="|p_end / p_in|", title=case_title(result["inputs"]))
    ax_p.set(xlabel="frequency (Hz)", ylabel="phase (deg)")
    ax_a.legend(fontsize=8.5)
    for ax in (ax_a, ax_p):
        ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    return fig


def step_figure(result: dict) -> Figure:
    """Chamber and valve-port pressure of every model in the fixed-volume step test."""
    step = result["step"]
    fig = Figure(figsize=(6.4, 5.6))
    ax_c, ax_v = fig.subplots(2, 1, sharex=True)
    t = step["time_s"]
    for name, m in step["models"].items():
        ax_c.plot(t, [p / 1e5 for p in m["chamber_pressure_Pa"]], color=MODEL_COLOURS[name], label=name)
        ax_v.plot(t, [p / 1e5 for p in m["valve_pressure_Pa"]], color=MODEL_COLOURS[name])
    for ax in (ax_c, ax_v):
        ax.axvline(step["valve_reversal_s"], color="0.4", ls=":", lw=1.2,
                   label=f"valve vents ({step['valve_reversal_s']:g} s)")
        ax.axhline(result["inputs"]["pressure_Pa"] / 1e5, color="0.3", ls="--", lw=0.8, label="supply")
        ax.grid(True, alpha=0.3)
    ax_c.set(ylabel="chamber P (bar abs)",
             title=f"fixed-volume step, valve {step['valve']}\n{case_title(result['inputs'])}")
    ax_v.set(xlabel="time (s)", ylabel="valve port P (bar abs)")
    ax_c.legend(fontsize=8.5)
    fig.tight_layout()
    return fig
