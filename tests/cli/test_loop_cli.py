"""dacm loop and the experiment runner: JSON output, plots, bad input, capacity warning, runaway
estimates, the DACM sensor in the loop."""
import json
import math

import pytest

from sensor.cli import main
from sensor.errors import SensorError
from sensor.pneumatic.dacm_sensor import DacmForceSensor
from sensor.pneumatic.experiment import Setup, run

FAST = ["--line-length", "1", "--segments", "4", "--duration", "2"]


def test_loop_json_reports_the_mses_and_writes_the_plot(tmp_path, capsys):
    assert main(["loop", *FAST, "--reference", "sine:2Hz", "--amplitude", "10", "--json", "--out", str(tmp_path)]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["controller"] == "pi" and out["observer"] == "force"
    # 10 N amplitude: doing nothing scores A^2 / 2 = 50 N^2; PI on a 1 m line tracks to
    # 1.7 N^2 (measured), so a tenth of the do-nothing score catches a broken loop
    assert 0 < out["force_mse_N2"] < 5.0
    assert math.isfinite(out["pressure_mse_kPa2"]) and out["valve_pressure_mse_kPa2"] < 1.0   # 1 m: ports = chambers
    assert out["window_s"][1] == pytest.approx(2.0, abs=2e-3) and (tmp_path / "loop.png").stat().st_size > 10_000
    assert isinstance(out["settled"], bool) and out["duration_s"] == 2.0


def test_line_model_json_has_the_virtual_input_mse(capsys):
    assert main(["loop", *FAST, "--controller", "line-model-damped", "--observer", "standard", "--line-length", "7.25",
                 "--reference", "sine:1Hz",
                 "--amplitude", "10", "--json", "--no-plots"]) == 0
    out = json.loads(capsys.readouterr().out)
    # the inner loop tracks its virtual valve force (measured 0.08 N^2) and the outer loop
    # the force (0.11 N^2), far below the 50 N^2 of doing nothing
    assert out["valve"] == "enfield-lh05" and 0 < out["virtual_input_mse_N2"] < 1.0
    assert out["force_mse_N2"] < 5.0
    assert set(out["gains"]) == {"lam_per_s", "kp1", "ki1_per_s", "kp2_per_s", "ki2_per_s2",
                                 "flow_rate_per_s"}   # section 5.4.2
    assert out["gains"]["flow_rate_per_s"] > 0                 # ours: line-flow damping k_m
    assert out["line_model_pressure_mse_kPa2"] < out["pressure_mse_kPa2"]     # Figure 37's claim


def test_friction_spool_and_energy_flags_reach_the_plant(capsys):
    # the thesis' 0.25 N stiction, a 100 Hz spool and the energy equation: the JSON echoes them,
    # and the plant built from the same Setup carries them (stick-slip on, spool first order at
    # 2 pi 100 rad/s, energy equation with the stated wall conductance)
    from sensor.pneumatic.experiment import ENERGY_WALL_W_K, build_plant
    assert main(["loop", *FAST, "--stiction", "0.25", "--coulomb", "0.1", "--spool-bandwidth", "100", "--energy",
                 "--json", "--no-plots"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert (out["stiction_N"], out["coulomb_N"], out["spool_bandwidth_Hz"], out["energy"]) == (0.25, 0.1, 100.0, True)
    pc = build_plant(Setup(stiction_N=0.25, coulomb_N=0.1, spool_bandwidth_Hz=100.0, energy=True)).compile().pc[0]
    assert pc["stick"] and pc["static_friction"] == 0.25 and pc["coulomb"] == 0.1
    assert pc["spool_order"] == 1 and pc["spool_w"] == pytest.approx(2 * math.pi * 100.0)
    assert pc["energy"] and list(pc["wall_ha"]) == [ENERGY_WALL_W_K, ENERGY_WALL_W_K]
    assert math.isfinite(out["force_mse_N2"]) and out["status"] in ("settled", "limit_cycle", "unsettled")


@pytest.mark.parametrize("flag,value,needle", [("--controller", "pid", "--controller 'pid'"),
                                               ("--observer", "kalman", "--observer 'kalman'"),
                                               ("--study", "chapter9", "--study 'chapter9'"),
                                               ("--reference", "ramp", "reference = 'ramp'"),
                                               ("--sensor", "sample-z", "sensor = 'sample-z'")])
def test_unknown_names_exit_2_with_one_line(flag, value, needle, capsys):
    assert main(["loop", *FAST, "--no-plots", flag, value]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and needle in err and err.startswith("dacm loop: error:")


def test_reference_beyond_the_force_capacity_warns_with_the_capacity(capsys):
    assert main(["loop", *FAST, "--duration", "0.5", "--amplitude", "150", "--no-plots"]) == 0
    err = capsys.readouterr().err
    # (P_s - P_atm) A1 = 498675 Pa * pi 0.016^2 / 4 = 100.3 N for the default 16 mm cylinder
    assert "force capacity [-90.47, 100.3] N" in err and err.startswith("dacm loop: warning:")


def test_a_runaway_estimate_stops_the_run_naming_it():
    class Broken:
        def read(self, value, t):
            return math.nan if t > 0.1 else value
    with pytest.raises(SensorError, match=r"observer stopped at t = 0\.10\d* s: estimated chamber pressure P_hat_1 = nan"):
        run(Setup(line_length_m=1.0, segments=4, duration_s=0.5, force_sensor=Broken()))


def test_dacm_sensor_in_the_loop_reads_the_contact_force():
    # Sample A (range ~3.3 N, hysteresis ~5 % FS): its reading of the contact force stays within
    # the hysteresis band (half the loop height, 2.5 % of the range) plus noise of the true force.
    fs = DacmForceSensor("sample-a-as-cut")
    from sensor.pneumatic.cylinder import spring_contact
    from sensor.pneumatic.dacm_sensor import series_spring
    s = Setup(reference="sine:1Hz", amplitude_N=0.35 * fs.range_N, offset_N=0.5 * fs.range_N, line_length_m=1.0,
              segments=4, duration_s=2.0, force_sensor=fs,
              environment=spring_contact(series_spring(2000.0, fs.stiffness_N_m), 0.025))
    ds = run(s)
    w = ds.sel(time=slice(1.0, 1.999))
    err = (w.measured_force_N - w.environment_force)
    assert float(abs(err).max()) < 0.03 * fs.range_N + 0.01
    assert float(((w.desired_force_N - w.environment_force) ** 2).mean()) < 0.5


def test_loop_with_a_dacm_sensor_picks_a_reference_within_its_range(capsys):
    # sample A's range is 3.37 N: the default 24 N reference would be 7 times its range; the
    # command takes 15-85 % of the range instead and says so on stderr
    assert main(["loop", *FAST, "--sensor", "sample-a-as-cut", "--json", "--no-plots"]) == 0
    cap = capsys.readouterr()
    out = json.loads(cap.out)
    rng = DacmForceSensor("sample-a-as-cut").range_N
    assert out["amplitude_N"] == pytest.approx(0.35 * rng) and out["offset_N"] == pytest.approx(0.5 * rng)
    assert "note: reference within the sensor's" in cap.err and "warning" not in cap.err


def test_progress_only_on_a_terminal_and_never_with_quiet(monkeypatch, capsys):
    from sensor.cli.progress import counting
    with counting("study") as progress:          # pytest's stderr is not a terminal: nothing drawn
        progress(1, 2, "smc sine:1Hz 5 m")
    assert capsys.readouterr() == ("", "")
    monkeypatch.setattr("sys.stderr.isatty", lambda: True)
    with counting("study", quiet=True) as progress:
        progress(1, 2, "smc sine:1Hz 5 m")
    assert capsys.readouterr() == ("", "")
    with counting("study") as progress:
        progress(1, 2, "smc sine:1Hz 5 m")
        progress(2, 2, "smc sine:2Hz 5 m")
    assert capsys.readouterr().out == ""                 # the display goes to stderr only


def test_default_duration_settles(capsys):
    # no --duration: 30 s (or 25 periods), long enough for the settling rule on the default loop
    assert main(["loop", "--line-length", "1", "--segments", "4", "--no-plots", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["duration_s"] == 30.0 and out["settled"] is True and out["window_s"] == [28.0, 30.0]


def test_a_single_run_is_named_by_the_same_rule_as_the_studies(capsys):
    # dacm loop measures a run as the studies do (experiment.measure): the damped line model at
    # 7.25 m, 0.5 Hz fails the 10 % block bound on its sensors' noise and is settled by its
    # noise-free twin, which the JSON and the console say
    args = ["loop", "--controller", "line-model-damped", "--observer", "standard", "--reference", "sine:0.5Hz",
            "--no-plots"]
    assert main([*args, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["status"] == "settled" and out["settled_by"] == "noise_free_twin" and out["noise_block_change"] > 0.10
    assert out["settling"]["noise_free_twin"]["block_change"] < 0.01
    assert main(args) == 0
    assert "settled by its noise-free twin, its own blocks" in capsys.readouterr().out
