"""`discover` on the channels a car records (issue 28): an IMU only (yaw rate psi_dot and lateral
acceleration a_y), with or without a speed that changes, at 10 to 40 runs. The data come from the
hidden-effect reality (uqdrive.studies.hidden_effects), code apart from the model's."""

import copy
import dataclasses
import json

import numpy as np
import pytest
import yaml

from uqdrive.cli import main
from uqdrive.inference.discrepancy import DiscrepancyFinder
from uqdrive.io import write_dataset
from uqdrive.rng import rng_stream
from uqdrive.studies.hidden_effects import HiddenEffectCase, draw_realisations, generate, simulate_channels, wind_kle
from uqdrive.vehicle.augmented import AugmentedSimulator
from uqdrive.vehicle.channels import CHANNELS
from uqdrive.vehicle.effects import EFFECTS, ModelStructure
from uqdrive.vehicle.uncertainty import Germs
from uqdrive.settings import Settings

IMU = ("psi_dot", "a_y")
BRAKING = {"start_kmh": 70.0, "end_kmh": 45.0, "t_brake": 1.0, "duration": 2.0}  # -3.5 m/s^2, the speed falls by 36 %


@pytest.fixture(scope="module")
def short(config):
    """4 s on a 0.02 s grid and a reduced discovery (fewer model realisations, replicates, times)."""
    c = copy.deepcopy(config)
    c["time"].update(t_end=4.0, dt=0.02, step=0.01)
    c["discrepancy"].update(model_samples=200, nonlinear_samples=60, bootstrap=40, max_times=50, top=2, posterior={"enabled": False})
    return c


@pytest.mark.parametrize("effect, size, channel, speed", [("road_bank", 3.0, None, False), ("actuator_lag", 0.15, None, True),
                                                          ("sensor_scale", 1.2, "a_y", True)])
def test_model_channels_are_the_reality_s(short, effect, size, channel, speed):
    """One realisation of the model (mu, l_f, load, mean wind as the reality's draw, no gusts) against
    the independent reality: every channel, a_y included, at constant speed and while braking.
    Tolerance: both are RK4 or exact discretisations of the same linear model (steps 0.005 and
    0.01 s: relative errors ~1e-4 of each channel's range); a_y read as v (beta_dot + psi_dot)
    (a bank's gravity felt) would be off by g sin(3 deg) = 0.51 m/s^2, a third of its range."""
    cfg = copy.deepcopy(short)
    cfg["wind"]["sigma"] = 0.0
    case = HiddenEffectCase("x", effect, size, "step", {"amplitude_deg": 2.0}, samples=1, seed=5, channel=channel,
                            speed=BRAKING if speed else {})
    draws = draw_realisations(cfg, case, wind_kle(cfg))
    t, delta, x, a_y, v = simulate_channels(cfg, case, draws)
    truth = np.concatenate([x[:, 0], a_y])  # (5, T)
    germs = Germs(mu=np.zeros(1), l_f=np.zeros(1), m_load=np.zeros(1), wind=np.zeros(1), kle=np.zeros((1, 30)))
    cfg["uncertainty"]["m_load"] = {"mean": float(draws["m_load"][0]), "std": 0.0}
    theta = [draws["mu"][0], 0.0, draws["l_f"][0], 0.0, draws["F_w_mean"][0], draws["F_w_mean"][0]]
    s = ModelStructure() if effect == "none" else EFFECTS[{"sensor_scale": "sensor_scale_a_y"}.get(effect, effect)].augment(ModelStructure(), [size])
    sim = AugmentedSimulator(Settings.from_config(cfg), t, delta, float(v[0]), germs, channels=CHANNELS, speed=v if speed else None)
    model = sim.simulate(theta, s)[:, 0]
    gain = size if effect == "sensor_scale" else 1.0
    truth[4] *= gain
    span = np.ptp(truth, axis=1)
    np.testing.assert_array_less(np.abs(model - truth).max(axis=1), 2e-3 * span)


@pytest.mark.parametrize("runs, manoeuvre, seed", [(10, "chirp", 31), (20, "lane_change", 32), (40, "step", 33)])
def test_imu_only_null_says_none(short, runs, manoeuvre, seed):
    """No missing effect, yaw rate and lateral acceleration only: `none` at 10, 20 and 40 runs,
    the band bootstrapped over exactly those two channels at that run count; the y-only candidate
    is reported untestable, the sensor errors of unrecorded channels are not tried at all."""
    case = HiddenEffectCase("null", "none", 0.0, manoeuvre, {"amplitude_deg": 2.0}, samples=runs, seed=seed)
    f = DiscrepancyFinder(Settings.from_config(short)).fit(generate(short, case, channels=IMU))
    v = f.verdict_
    assert v["effect"] == "none" and not v["evidence"]["significant"]
    assert f.measured_.shape[1] == 2 and f.band_.cell_scale.shape[1] == 2 and v["evidence"]["channels"] == list(IMU)
    assert [u["effect"] for u in v["untestable"]] == ["lateral_kinematics"] and "without y" in v["untestable"][0]["reason"]
    assert not {"sensor_bias_psi", "sensor_bias_beta", "sensor_bias_y", "sensor_scale_beta", "lateral_kinematics"} & set(f.candidates_)
    assert {"sensor_bias_a_y", "sensor_scale_psi_dot", "road_bank", "tyre_saturation"} <= set(f.candidates_)


def test_imu_names_an_accelerometer_bias(short):
    """A 0.3 m/s^2 offset on a_y (a tilted accelerometer), IMU only, 20 runs: named on a_y with its
    size in the interval. Without a_y in the comparison nothing could be named."""
    case = HiddenEffectCase("bias", "sensor_bias", 0.3, "lane_change", {"amplitude_deg": 2.0}, samples=20, seed=41, channel="a_y")
    v = DiscrepancyFinder(Settings.from_config(short), candidates=["sensor_bias", "actuator_lag"]).fit(generate(short, case, channels=IMU)).verdict_
    assert v["effect"] == "sensor_bias" and v["parameters"]["channel"] == "a_y"
    est, lo, hi = v["parameters"]["offset_a_y"]
    assert lo <= 0.3 <= hi and abs(est - 0.3) < 0.05


def test_discover_cli_on_an_imu_file_while_braking(short, tmp_path, capsys):
    """The CLI on a file with psi_dot, a_y and a speed `v` falling from 70 km/h by 27 %, 20 runs, no missing
    effect: exit 0, `none`, and verdict.json says which channels and speeds it compared and what
    it could not test."""
    case = HiddenEffectCase("null", "none", 0.0, "step", {"amplitude_deg": 2.0}, samples=20, seed=51, speed=BRAKING)
    cheap = copy.deepcopy(short)  # the time-varying model integrates by RK4: a shorter run, fewer realisations and times
    cheap["time"]["t_end"] = 2.5
    cheap["discrepancy"].update(model_samples=60, bootstrap=30, max_times=20)
    measured = tmp_path / "imu.nc"
    write_dataset(generate(cheap, case, channels=IMU), measured)
    cfg = tmp_path / "config.yaml"
    cfg.write_text(yaml.safe_dump(cheap))
    code = main(["discover", str(measured), "--config", str(cfg), "--candidates", "actuator_lag,lateral_kinematics", "--out", str(tmp_path / "out")])
    assert code == 0, capsys.readouterr().err
    v = json.loads((tmp_path / "out" / "verdict.json").read_text())
    assert v["effect"] == "none" and v["evidence"]["channels"] == list(IMU)
    assert v["evidence"]["speed_profile"]["max"] == pytest.approx(70 / 3.6) and v["evidence"]["speed_profile"]["min"] < 0.8 * 70 / 3.6  # fell by more than 20 %
    assert [u["effect"] for u in v["untestable"]] == ["lateral_kinematics"]


def test_the_channel_table_runs_discover_on_each_cell_without_the_posterior(config, monkeypatch):
    """channel_detection: one discover per case, channel set and run count, on a file with exactly
    that set's channels and run count (a speed falling for imu_speed), the emcee posterior off
    (the table reports verdicts; the full config samples it for tyre_saturation, minutes a cell)."""
    import uqdrive.inference.discrepancy as discrepancy
    from uqdrive.studies.discrepancy import channel_detection, channel_detection_cell
    from uqdrive.studies.hidden_effects import HiddenEffectCase

    seen = []

    class Recorder:
        def __init__(self, cfg, **kwargs):
            seen.append(kwargs)

        def fit(self, data):
            seen[-1].update(channels=sorted(v for v in data.data_vars if v not in ("delta", "v")), runs=data.sizes["sample"],
                            braking="v" in data)
            self.verdict_ = {"effect": "road_bank", "untestable": []}
            return self

    monkeypatch.setattr(discrepancy, "DiscrepancyFinder", Recorder)
    cfg = {**config, "time": {**config["time"], "t_end": 2.0}}
    case = HiddenEffectCase("bank", "road_bank", 2.0, "step", {"amplitude_deg": 2.0}, samples=10, seed=1)
    rows = channel_detection(cfg, [case], ["all", "imu_speed"], [10, 12])
    assert [(r["set"], r["runs"], r["verdict"], r["correct"]) for r in rows] == [
        ("all", 10, "road_bank", True), ("imu_speed", 10, "road_bank", True), ("all", 12, "road_bank", True), ("imu_speed", 12, "road_bank", True)]
    assert all(s["posterior"] is False for s in seen)
    assert [(s["channels"], s["runs"], s["braking"]) for s in seen[:2]] == [(["a_y", "beta", "psi", "psi_dot", "y"], 10, False),
                                                                            (["a_y", "psi_dot"], 10, True)]
    # one cell (the workflow's job) is its column of the table: the same row, built alone
    cell = channel_detection_cell(cfg, [case], "imu_speed", 12)
    drop = lambda r: {k: v for k, v in r.items() if k != "seconds"}  # noqa: E731
    assert [drop(r) for r in cell] == [drop(rows[3])] and (seen[-1]["channels"], seen[-1]["runs"], seen[-1]["braking"]) == (["a_y", "psi_dot"], 12, True)
