"""One ``dacm loop --study`` run: the study, its tables and verdicts as text, its JSON
answer and the figures it draws (chapters IV-V; DESIGN section 15)."""

from __future__ import annotations


def run_study(study: str, progress=None, **kw) -> tuple:
    """(results, tables as Markdown text, JSON answer, {file name: figure maker}) of the
    ``observer``, ``controllers``, ``plant-physics`` or ``sensor`` study; ``kw`` go to the
    study (segments, duration_s)."""
    from sensor.pneumatic import plots
    from sensor.pneumatic import studies as st
    from sensor.pneumatic import verdicts as vd

    if study == "observer":
        res = st.observer_study(progress=progress, **kw)
        text, out = vd.observer_tables(res), {"experiments": res["experiments"], "switch_on": res["switch_on"],
                                               "verdicts": vd.observer_verdicts(res)}
        figs = {"loop-observer-phase.png": plots.observer_phase_figure, "loop-observer-smc.png": plots.observer_smc_figure}
    elif study == "controllers":
        keep = {(5.0, "sine:1Hz", k) for k in ("line_model_thesis", "line_model_damped")}
        res = st.controller_study(keep_runs=keep, progress=progress, **kw)
        text, out = vd.controller_tables(res), {"rows": res["rows"], "tuning": res["tuning"], "verdicts": {
            k: vd.controller_verdicts(res, k, smc) for k, smc in (("line_model_thesis", "smc"),
                                                                  ("line_model_thesis_rule", "smc_rule"),
                                                                  ("line_model_damped", "smc_rule"))}}
        figs = {"loop-controllers-mse.png": plots.controller_mse_figure,
                "loop-controllers-virtual-input.png": plots.controller_virtual_input_figure}
    elif study == "plant-physics":
        res = st.plant_physics_study(progress=progress, **kw)
        text, out = vd.plant_physics_tables(res), {"variants": res["variants"], "rows": res["rows"],
                                                   "tuning": res["tuning"]}
        figs = {}
    else:
        res = st.sensor_study(progress=progress, **kw)
        text, out = vd.sensor_tables(res), {"rows": res["rows"]}
        figs = {"loop-sensor.png": plots.sensor_figure}
    return res, text, out, figs
