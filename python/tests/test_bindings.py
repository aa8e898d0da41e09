"""Each binding against the `rom` command on the same input (docs/python.md).

The CLI is the release binary of this workspace: $BELTWIN_ROM, else target/release/rom.
"""

import csv
import json
import shutil
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import beltwin

REPO = Path(__file__).resolve().parents[2]
ROM = Path(os.environ.get("BELTWIN_ROM", REPO / "target" / "release" / "rom"))


def rom(*args, check=True):
    """Runs `rom ARGS`; returns the completed process."""
    p = subprocess.run([str(ROM), *map(str, args)], capture_output=True, text=True)
    if check and p.returncode != 0:
        raise AssertionError(f"rom {' '.join(map(str, args))} failed: {p.stderr}")
    return p


def cli_error(*args):
    """The message `rom ARGS` prints on failure, without its `error: ` prefix."""
    p = rom(*args, check=False)
    assert p.returncode != 0, p.stdout
    assert p.stderr.startswith("error: "), p.stderr
    return p.stderr[len("error: "):].strip()


def labels_of(source, labels, d):
    """Copies the recordings of `labels` of the data set `source` into the data set `d`."""
    text = (source / "manifest.toml").read_text()
    head, *runs = text.split("[[run]]")
    kept = [r for r in runs if any(f'label = "{x}"' in r for x in labels)]
    assert len(kept) == len(labels), text
    for r in kept:
        name = r.split('file = "', 1)[1].split('"', 1)[0]
        shutil.copy(source / name, d / name)
    (d / "manifest.toml").write_text(head + "".join("[[run]]" + r for r in kept))
    return d


@pytest.fixture(scope="session")
def measured(tmp_path_factory):
    """A small `belt-measurements/1` data set: three labels of the shipped sample data set with
    fan-bearing drag (3 s recordings of the full-order model, examples/data/make.sh)."""
    d = tmp_path_factory.mktemp("measured")
    return labels_of(REPO / "examples" / "data" / "effect", ["d0", "d1", "d2"], d)


@pytest.fixture(scope="session")
def shipped():
    return beltwin.Surrogate.load()


def test_predict_equals_the_cli_json(shipped):
    for args in [(0.42,), (0.4165, 0.65, 210.0)]:
        flags = ["--d", args[0]]
        kw = {}
        if len(args) > 1:
            flags += ["--mu", args[1], "--tension", args[2]]
            kw = {"mu": args[1], "tension": args[2]}
        cli = json.loads(rom("predict", *flags, "--format", "json").stdout)
        py = shipped.predict(args[0], **kw)
        qf = py.pop("quantile_function_pct")
        assert isinstance(qf, np.ndarray) and qf.shape == (len(cli["quantile_function_pct"]), 2)
        assert np.array_equal(qf, np.array(cli.pop("quantile_function_pct")))
        assert py == cli


def test_predict_many_equals_predict_row_by_row(shipped):
    pts = np.array([[0.416, 0.7, 250.0], [0.42, 0.65, 220.0], [0.4235, 0.78, 290.0]])
    many = shipped.predict_many(pts, samples=50)
    assert many["quantiles_pct"].shape == (3, 5)
    assert many["quantile_function_pct"].shape == (3, len(many["probability_levels"]))
    for i, (d, mu, t) in enumerate(pts):
        one = shipped.predict(d, mu=mu, tension=t, samples=50)
        assert many["mean_slip_pct"][i] == one["mean_slip_pct"]
        assert many["surrogate_std_pct"][i] == one["surrogate_std_pct"]
        q = one["quantiles_pct"]
        assert list(many["quantiles_pct"][i]) == [q["p05"], q["p25"], q["p50"], q["p75"], q["p95"]]
        assert np.array_equal(many["quantile_function_pct"][i], one["quantile_function_pct"][:, 1])
    # One column: d alone, at the configuration's friction and tension.
    d_only = shipped.predict_many(np.array([[0.42]]))
    assert d_only["mean_slip_pct"][0] == shipped.predict(0.42)["mean_slip_pct"]


def test_errors_carry_the_cli_message(shipped, tmp_path):
    with pytest.raises(beltwin.BeltwinError) as e:
        shipped.predict(0.43)
    cli = cli_error("predict", "--d", 0.43)
    assert str(e.value).split(";")[0] == cli.split(";")[0]
    assert "allow_extrapolation=True" in str(e.value)
    # A point no drive can have (the belt would have to stretch past its rating): the same
    # reason as the CLI's, which names the flag; refused even with allow_extrapolation.
    cli = cli_error("predict", "--d", 0.5, "--allow-extrapolation")
    assert cli.startswith("--d: "), cli
    for allow in (False, True):
        with pytest.raises(beltwin.BeltwinError) as e:
            shipped.predict(0.5, allow_extrapolation=allow)
        assert str(e.value).split(";")[0] == cli[len("--d: "):].split(";")[0]
    with pytest.raises(beltwin.BeltwinError) as e:
        shipped.predict_many(np.zeros((2, 5)))
    assert "1 to 4 columns" in str(e.value)
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "manifest.toml").write_text('format = "belt-measurements/1"\nrun = []\n')
    with pytest.raises(beltwin.BeltwinError) as e:
        beltwin.read_measurements(bad)
    assert str(e.value) == cli_error("diagnose", "--measured", bad)
    with pytest.raises(beltwin.BeltwinError) as e:
        beltwin.Surrogate.load(tmp_path / "missing.json")
    assert str(e.value) == cli_error("predict", "--d", 0.42, "--model", tmp_path / "missing.json")


def test_simulate_equals_the_cli_csv(tmp_path):
    out = tmp_path / "run.csv"
    rom("simulate", "--d", 0.418, "--mu", 0.68, "--duration", 0.3, "--out", out)
    py = beltwin.simulate(d=0.418, mu=0.68, duration=0.3)
    with open(out) as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == len(py["time_s"])
    # The CSV carries each column to a fixed number of decimals (fom::output::write_run_csv).
    decimals = {"time_s": 6, "driver_rpm": 4, "driven_rpm": 4, "slip_pct": 5,
                "tight_span_tension_n": 3, "slack_span_tension_n": 3,
                "driver_torque_nm": 5, "driven_torque_nm": 5}
    for name, places in decimals.items():
        cli = np.array([float(r[name]) if r[name] else np.nan for r in rows])
        got = py[name]
        assert isinstance(got, np.ndarray)
        both = ~np.isnan(cli)
        assert np.array_equal(both, ~np.isnan(got)), name
        assert np.max(np.abs(cli[both] - got[both])) <= 0.5 * 10.0**-places * (1 + 1e-9), name
    assert py["summary"]["simulated_s"] == pytest.approx(0.3)
    assert "[belt]" in py["config"]


def test_read_measurements_returns_the_recordings(measured):
    m = beltwin.read_measurements(measured)
    assert m["format"] == "belt-measurements/1"
    assert [r["label"] for r in m["runs"]] == ["d0", "d1", "d2"]
    run = m["runs"][1]
    assert run["center_distance_m"] == 0.421
    with open(measured / run["file"]) as f:
        rows = [r for r in csv.reader(f) if r and not r[0].startswith("#")]
    header, data = rows[0], np.array(rows[1:], dtype=float)
    for j, name in enumerate(header):
        assert np.array_equal(run[name], data[:, j]), name


def test_diagnose_equals_the_cli_report(measured, tmp_path):
    rom("diagnose", "--measured", measured, "--report", tmp_path)
    cli = json.loads((tmp_path / "diagnosis.json").read_text())
    assert beltwin.diagnose(measured) == cli


def test_calibrate_equals_the_cli_json(measured):
    cli = json.loads(rom("calibrate", "--measured", measured, "--no-confirm",
                         "--free", "friction,tension", "--format", "json").stdout)
    py = beltwin.calibrate(measured, free=["friction", "tension"], confirm=False)
    assert py == cli
    assert py["leave_one_out"] is None


@pytest.fixture(scope="session")
def measured_pair(measured, tmp_path_factory):
    """Two labels of `measured` (d0 and d2), the least a gap diagnosis takes: the binding and
    the CLI run it once each, so the smaller set halves the time of the comparison."""
    return labels_of(measured, ["d0", "d2"], tmp_path_factory.mktemp("pair"))


def test_gap_equals_the_cli_json(measured_pair):
    # The CLI runs in its own process while the binding runs here: both at once, on two cores.
    args = [str(ROM), "gap", "--measured", str(measured_pair), "--format", "json"]
    p = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    py = beltwin.gap(measured_pair)
    out, err = p.communicate()
    assert p.returncode == 0, err
    cli = json.loads(out)
    # The wall time of each run is the one field that differs.
    assert py.pop("elapsed_s") > 0 and cli.pop("elapsed_s") > 0
    assert py == cli


def test_a_long_simulation_stops_on_ctrl_c():
    """The run releases the GIL and checks for signals while it runs: Ctrl-C (SIGINT) ends it
    with KeyboardInterrupt within a second, not at the end of its 60 simulated seconds. The
    child installs Python's own Ctrl-C handler first: a process started in the background
    (`cmd &` in a script, as a CI runner may) inherits SIGINT ignored, and Python then
    installs none, so the test would hang on the runner, not on the binding."""
    code = (
        "import beltwin, signal, sys\n"
        "signal.signal(signal.SIGINT, signal.default_int_handler)\n"
        "print('started', flush=True)\n"
        "try:\n"
        "    beltwin.simulate(duration=60.0)\n"
        "except KeyboardInterrupt:\n"
        "    print('interrupted', flush=True)\n"
        "    sys.exit(3)\n"
    )
    p = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "started"
    time.sleep(2.0)
    sent = time.monotonic()
    p.send_signal(signal.SIGINT)
    out, _ = p.communicate(timeout=30)
    assert p.returncode == 3 and "interrupted" in out
    assert time.monotonic() - sent < 5.0


def test_tooth_surrogate_equals_the_cli_json():
    """The shipped tooth-load surrogate against `rom predict --config TOOTHED`."""
    config = REPO / "fom" / "configs" / "synchronous-arc.toml"
    s = beltwin.Surrogate.load(config=config)
    assert s.kind == "tooth-load"
    # The former class name still loads the same model.
    assert beltwin.ToothSurrogate.load().kind == "tooth-load"
    for kw, flags in [
        ({}, []),
        (
            {"side_gap": 2.5e-4, "load_torque": 5.0, "shaft_load": 420.0},
            ["--side-gap", "2.5e-4", "--load-torque", 5.0, "--shaft-load", 420.0],
        ),
    ]:
        got = s.predict(**kw)
        want = json.loads(rom("predict", "--config", config, *flags, "--format", "json").stdout)
        assert got.keys() == want.keys()
        for key in ["mean_peak_n", "max_n", "side_gap_m", "load_torque_nm", "shaft_load_n"]:
            assert got[key] == pytest.approx(want[key], rel=1e-12), key
        assert got["peak_quantiles_n"] == pytest.approx(want["peak_quantiles_n"], rel=1e-12)
    # Outside the trained box: the CLI's refusal, worded with the Python keyword.
    with pytest.raises(beltwin.BeltwinError, match="allow_extrapolation=True"):
        s.predict(side_gap=5e-4)
    assert s.predict(side_gap=5e-4, allow_extrapolation=True)["extrapolated"]
