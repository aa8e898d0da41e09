"""The FMUs of `rom export-fmu` driven by a real importer, FMPy (docs/guide/export-fmu.md).

The surrogate FMU against `rom predict --format json`; the full-order FMU against `rom
simulate`'s rows at full precision, read through the binding of the same library function
(`beltwin.simulate`: the CSV of `rom simulate --out` rounds speeds to 1e-4 rpm).
"""

import json
import os
import shutil
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest

try:
    import fmpy
    from fmpy import simulate_fmu, read_model_description
    from fmpy.fmi2 import FMU2Slave
    from fmpy.validation import validate_fmu
except ImportError:  # pragma: no cover - the message is the point
    pytest.fail(
        "FMPy is not installed: run python/test.sh (it installs fmpy into target/py-venv)",
        pytrace=False,
    )

import beltwin

REPO = Path(__file__).resolve().parents[2]
ROM = Path(os.environ.get("BELTWIN_ROM", REPO / "target" / "release" / "rom"))
# The default drive's output interval (fom/configs/hvac.toml): rows of `rom simulate`.
ROW_S = 1.0e-3


def rom(*args):
    p = subprocess.run([str(ROM), *map(str, args)], capture_output=True, text=True)
    assert p.returncode == 0, f"rom {' '.join(map(str, args))} failed: {p.stderr}"
    return p.stdout


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    """Both FMUs of the default drive, exported, and each unpacked once."""
    d = tmp_path_factory.mktemp("fmu")
    out = {}
    for kind in ["surrogate", "fom"]:
        path = d / f"{kind}.fmu"
        rom("export-fmu", "--kind", kind, "--out", path)
        unpacked = d / kind
        with zipfile.ZipFile(path) as z:
            z.extractall(unpacked)
        out[kind] = (path, unpacked)
    return out


class Log:
    """The FMU's messages through FMPy's logger callback."""

    def __init__(self):
        self.messages = []

    def __call__(self, component, instance, status, category, message):
        self.messages.append((status, message.decode()))

    def text(self):
        return "\n".join(m for _, m in self.messages)


def test_fmpy_finds_no_problem(fmus):
    for kind, (path, _) in fmus.items():
        assert validate_fmu(str(path)) == [], kind


def test_model_description_carries_units_ranges_and_a_stable_token(fmus, tmp_path):
    md = read_model_description(str(fmus["surrogate"][0]))
    ranges = json.loads(rom("info", "--format", "json"))
    v = {x.name: x for x in md.modelVariables}
    d = v["center_distance_m"]
    assert (d.unit, d.causality) == ("m", "input")
    for x in ranges["inputs"]:
        assert [float(v[x["input"]].min), float(v[x["input"]].max)] == x["trained"], x
    assert v["installation_tension_n"].unit == "N"
    assert v["mean_slip_pct"].unit == "%" and v["extrapolated"].type == "Boolean"
    assert all(x.description for x in md.modelVariables)
    # The same export twice: the same token and the same bytes.
    again = tmp_path / "again.fmu"
    rom("export-fmu", "--kind", "surrogate", "--out", again)
    assert read_model_description(str(again)).guid == md.guid
    assert again.read_bytes() == fmus["surrogate"][0].read_bytes()
    fom = read_model_description(str(fmus["fom"][0]))
    assert fom.guid != md.guid
    assert {x.name: x.unit for x in fom.modelVariables}["driven_speed_rpm"] == "rpm"


OUTPUTS = {
    "mean_slip_pct": lambda j: j["mean_slip_pct"],
    "std_slip_pct": lambda j: j["std_slip_pct"],
    "slip_p05_pct": lambda j: j["quantiles_pct"]["p05"],
    "slip_p25_pct": lambda j: j["quantiles_pct"]["p25"],
    "slip_p50_pct": lambda j: j["quantiles_pct"]["p50"],
    "slip_p75_pct": lambda j: j["quantiles_pct"]["p75"],
    "slip_p95_pct": lambda j: j["quantiles_pct"]["p95"],
    "surrogate_std_pct": lambda j: j["surrogate_std_pct"],
}


def surrogate_at(unpacked, **start):
    r = simulate_fmu(str(unpacked), start_values=start, stop_time=1.0, step_size=1.0)
    return r[-1]


def test_surrogate_fmu_answers_rom_predict_over_a_sweep_of_d(fmus):
    _, unpacked = fmus["surrogate"]
    for d in np.linspace(0.4152, 0.4238, 5):
        row = surrogate_at(unpacked, center_distance_m=d)
        cli = json.loads(rom("predict", "--d", repr(float(d)), "--format", "json"))
        for name, pick in OUTPUTS.items():
            assert abs(row[name] - pick(cli)) <= 1e-12 * abs(pick(cli)), (d, name)
        assert not row["extrapolated"]


def test_surrogate_fmu_extrapolates_only_when_allowed(fmus):
    _, unpacked = fmus["surrogate"]
    log = Log()
    with pytest.raises(Exception):
        simulate_fmu(str(unpacked), start_values={"center_distance_m": 0.43}, stop_time=1.0,
                     step_size=1.0, logger=log)
    assert "outside the trained range" in log.text(), log.text()
    row = surrogate_at(unpacked, center_distance_m=0.43, allow_extrapolation=True)
    cli = json.loads(rom("predict", "--d", 0.43, "--allow-extrapolation", "--format", "json"))
    assert row["extrapolated"] and cli["extrapolated"]
    assert abs(row["mean_slip_pct"] - cli["mean_slip_pct"]) <= 1e-12 * cli["mean_slip_pct"]


def test_surrogate_fmu_refuses_a_point_outside_physics_with_a_message(fmus):
    _, unpacked = fmus["surrogate"]
    for start, word in [({"center_distance_m": 0.1}, "center_distance_m"),
                        ({"friction": -0.5}, "friction"),
                        ({"samples": 0}, "samples")]:
        log = Log()
        with pytest.raises(Exception):
            simulate_fmu(str(unpacked), start_values={**start, "allow_extrapolation": True},
                         stop_time=1.0, step_size=1.0, logger=log)
        assert any(s == 3 and word in m for s, m in log.messages), (start, log.text())


def run_fom(unpacked, stop_s, step_s, inputs=None):
    return simulate_fmu(str(unpacked), stop_time=stop_s, step_size=step_s,
                        output_interval=step_s, input=inputs)


def test_fom_fmu_equals_rom_simulate_for_3_s(fmus):
    _, unpacked = fmus["fom"]
    fmu = run_fom(unpacked, 3.0, ROW_S)
    ref = beltwin.simulate(duration=3.0)
    assert len(fmu) == len(ref["time_s"]) == 3001
    assert np.allclose(fmu["time"], ref["time_s"], rtol=0, atol=1e-9)
    for ours, theirs in [("driver_speed_rpm", "driver_rpm"), ("driven_speed_rpm", "driven_rpm"),
                         ("slip_pct", "slip_pct")]:
        a, b = fmu[ours][1:], ref[theirs][1:]
        ok = np.isfinite(b)
        assert np.array_equal(np.isfinite(a), ok), ours
        rel = np.abs(a[ok] - b[ok]) / np.maximum(np.abs(b[ok]), 1e-300)
        assert rel.max() <= 1e-9, (ours, rel.max())


def ramp_nm(t, start_s=0.15, end_s=0.3, torque_nm=4.0):
    """The half-cosine load ramp of `fom::drive` (`cosine-ramp` profile)."""
    f = np.clip((t - start_s) / (end_s - start_s), 0.0, 1.0)
    return torque_nm * 0.5 * (1.0 - np.cos(np.pi * f))


def test_fom_fmu_converges_to_rom_simulate_as_the_communication_step_shrinks(fmus, tmp_path):
    # The reference: the ramp inside the model, evaluated at every model step.
    toml = (REPO / "fom" / "configs" / "hvac.toml").read_text()
    toml += ('\n[driven.load.profile]\nkind = "cosine-ramp"\nstart_s = 0.15\nend_s = 0.3\n'
             'torque_nm = 4.0\n')
    cfg = tmp_path / "ramp.toml"
    cfg.write_text(toml)
    stop_s = 0.4
    ref = beltwin.simulate(config=str(cfg), duration=stop_s)
    _, unpacked = fmus["fom"]
    errors = []
    for h in [4 * ROW_S, 2 * ROW_S, ROW_S]:
        # The importer holds the input over each communication step (sampled at its start).
        t = np.arange(0.0, stop_s + h / 2, h)
        inputs = np.array([(x, True, y) for x, y in zip(t, ramp_nm(t))],
                          dtype=[("time", float), ("motor_on", bool),
                                 ("extra_load_torque_nm", float)])
        fmu = run_fom(unpacked, stop_s, h, inputs)
        k = round(h / ROW_S)
        # The reference's rows averaged over each communication step (a speed's mean over
        # equal rows is the mean over their union).
        driven = ref["driven_rpm"][1:].reshape(-1, k).mean(axis=1)
        errors.append(float(np.abs(fmu["driven_speed_rpm"][1:] - driven).max()))
    print("largest |driven speed error| (rpm) at h = 4, 2, 1 ms:", errors)
    # A held input is first order in the step: each halving halves the error (observed order
    # log2 of the ratio near 1).
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all((orders > 0.8) & (orders < 1.2)), (errors, orders)


def fresh_slave(unpacked, log=None):
    md = read_model_description(str(unpacked))
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=str(unpacked),
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="belt")
    if log is not None:
        from fmpy.fmi2 import (fmi2CallbackFunctions, fmi2CallbackLoggerTYPE,
                               fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE)
        from fmpy import calloc, free
        from fmpy.logging import addLoggerProxy
        cb = fmi2CallbackFunctions()
        cb.logger = fmi2CallbackLoggerTYPE(log)
        cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        addLoggerProxy(fmpy.fmi2.byref(cb))
        fmu.instantiate(callbacks=cb)
        fmu._keep = cb
    else:
        fmu.instantiate()
    vr = {v.name: v.valueReference for v in md.modelVariables}
    return fmu, vr


def test_fom_fmu_state_is_saved_and_restored(fmus):
    _, unpacked = fmus["fom"]
    fmu, vr = fresh_slave(unpacked)
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    out = [vr["driver_speed_rpm"], vr["driven_speed_rpm"], vr["tight_span_tension_n"]]
    for k in range(20):
        fmu.doStep(k * ROW_S, ROW_S)
    state = fmu.getFMUstate()
    fmu.setReal([vr["extra_load_torque_nm"]], [2.0])
    for k in range(20, 30):
        fmu.doStep(k * ROW_S, ROW_S)
    first = fmu.getReal(out)
    fmu.setFMUstate(state)  # the inputs too: set again
    fmu.setReal([vr["extra_load_torque_nm"]], [2.0])
    for k in range(20, 30):
        fmu.doStep(k * ROW_S, ROW_S)
    assert fmu.getReal(out) == first
    fmu.freeFMUstate(state)
    fmu.terminate()
    fmu.freeInstance()


def test_fom_fmu_refuses_calls_out_of_order_and_bad_steps(fmus):
    _, unpacked = fmus["fom"]
    log = Log()
    fmu, vr = fresh_slave(unpacked, log)
    with pytest.raises(Exception):
        fmu.doStep(0.0, ROW_S)
    assert "not allowed in the Instantiated phase" in log.text()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    for t, h, word in [(0.0, 1.5e-5, "whole number of model steps"),
                       (0.5, ROW_S, "communication points follow each other")]:
        with pytest.raises(Exception):
            fmu.doStep(t, h)
        assert word in log.text(), log.text()
    fmu.setReal([vr["extra_load_torque_nm"]], [float("nan")])
    with pytest.raises(Exception):
        fmu.doStep(0.0, ROW_S)
    assert "extra_load_torque_nm = NaN is not a finite torque" in log.text(), log.text()
    fmu.freeInstance()


def test_the_two_model_example_couples_the_duct_to_the_belt():
    """examples/fmu/cosim.py, 0.2 s of it: the duct's torque reaches the fan shaft."""
    import importlib.util
    spec = importlib.util.spec_from_file_location("cosim", REPO / "examples" / "fmu" / "cosim.py")
    cosim = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(cosim)
    rows = np.array(cosim.run(0.2))
    assert rows.shape == (200, 6)
    # Spinning up, the air column lags the fan (flow below k_q n): the duct unloads the shaft.
    assert np.all(rows[50:, 4] < 0) and np.all(np.diff(rows[:, 2]) > -1e-6)


def test_fom_fmu_reports_a_step_that_fails_and_stays_failed(fmus):
    """A load torque no drive sees (1e9 N m) blows the model up in its first step: the health
    check of `rom simulate` stops it, the importer gets fmi2Error and the reason."""
    _, unpacked = fmus["fom"]
    log = Log()
    fmu, vr = fresh_slave(unpacked, log)
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.setReal([vr["extra_load_torque_nm"]], [1e9])
    fmu.exitInitializationMode()
    with pytest.raises(Exception):
        fmu.doStep(0.0, ROW_S)
    assert "numerical failure" in log.text(), log.text()
    with pytest.raises(Exception):
        fmu.doStep(ROW_S, ROW_S)
    assert "not allowed in the Failed phase" in log.text(), log.text()
    fmu.freeInstance()
