"""Side-by-side of the beltwin surrogate with SMT, EZyRB and egobox (Python) on one data set.

Usage (after `rom train --data training-data` and `rom validate --json validation.json`):
    python3 studies/surrogate-comparison/compare_surrogates.py training-data validation.json

Every tool gets the same training runs and the same target: the steady-state slip quantile
function at 50 mid-point probability levels (numpy's default quantile = Hyndman-Fan 7, as in
beltwin), inputs (d, mu, T) scaled to the unit box. Each tool is used as its documentation shows:
POD by SVD at 99.9 % energy + one Kriging/GP per coefficient, hyperparameters optimised. The
truth is the full-order mean slip at the validation points of `rom validate`. Timings are taken
in this one process run, on this machine: fit time, and the latency of predicting the
distribution at one d with 200 friction samples (mu +-1 %), as `rom predict` does.
"""
import json
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import numpy as np

LEVELS = (np.arange(50) + 0.5) / 50


def load(data_dir):
    d = Path(data_dir)
    camp = tomllib.loads((d / "campaign.toml").read_text())["settings"]
    rows = np.genfromtxt(d / "points.csv", delimiter=",", names=True, dtype=None, encoding=None)
    X, Q = [], []
    for r in rows:
        if r["status"] != "ok":
            continue
        run = np.genfromtxt(d / "runs" / f"point-{int(r['index']):04d}.csv", delimiter=",",
                            names=True)
        s = run["slip_pct"][(run["time_s"] > camp["steady_start_s"]) & np.isfinite(run["slip_pct"])]
        X.append([r["center_distance_m"], r["friction"], r["installation_tension_n"]])
        Q.append(np.quantile(s, LEVELS))
    lo = np.array([camp["center_distance_m"][0], camp["friction"][0], camp["installation_tension_n"][0]])
    hi = np.array([camp["center_distance_m"][1], camp["friction"][1], camp["installation_tension_n"][1]])
    return (np.array(X) - lo) / (hi - lo), np.array(Q), lo, hi


def pod(Q, energy=0.999):
    mean = Q.mean(axis=0)
    u, s, vt = np.linalg.svd(Q - mean, full_matrices=False)
    k = int(np.searchsorted(np.cumsum(s**2) / np.sum(s**2), energy) + 1)
    return mean, vt[:k], (u[:, :k] * s[:k])


class PodSmt:
    name = "SMT 2 (KRG per POD coefficient)"

    def fit(self, X, Q):
        from smt.surrogate_models import KRG
        self.mean, self.modes, coef = pod(Q)
        self.gps = []
        for k in range(coef.shape[1]):
            gp = KRG(print_global=False, corr="matern52")
            gp.set_training_values(X, coef[:, k])
            gp.train()
            self.gps.append(gp)

    def predict(self, X):
        c = np.column_stack([gp.predict_values(X)[:, 0] for gp in self.gps])
        return self.mean + c @ self.modes


class PodEgobox:
    name = "egobox 1.0 Python (Gpx per POD coefficient)"

    def fit(self, X, Q):
        import egobox as egx
        self.mean, self.modes, coef = pod(Q)
        self.gps = [egx.Gpx.builder(corr_spec=egx.CorrelationSpec.MATERN52).fit(X, coef[:, k])
                    for k in range(coef.shape[1])]

    def predict(self, X):
        c = np.column_stack([np.ravel(gp.predict(X)) for gp in self.gps])
        return self.mean + c @ self.modes


class Ezyrb:
    name = "EZyRB 1.3 (POD + GPR)"

    def fit(self, X, Q):
        from ezyrb import GPR, POD, Database, ReducedOrderModel
        db = Database(X, Q)
        self.rom = ReducedOrderModel(db, POD("svd", rank=0.999), GPR())
        self.rom.fit()

    def predict(self, X):
        out = self.rom.predict(X)
        return np.array(out.snapshots_matrix if hasattr(out, "snapshots_matrix") else out)


def main():
    data_dir, val_json = sys.argv[1], sys.argv[2]
    X, Q, lo, hi = load(data_dir)
    val = json.loads(Path(val_json).read_text())["points"]
    val = [p for p in val if p["error"] is None]
    Xv = (np.array([[p["center_distance_m"], p["friction"], p["installation_tension_n"]]
                    for p in val]) - lo) / (hi - lo)
    truth = np.array([p["fom_mean_slip_pct"] for p in val])
    tol = np.maximum(0.05, 0.02 * np.abs(truth))
    q = np.array([0.42, 0.7, 250.0])
    mc = np.tile(q, (200, 1))
    mc[:, 1] *= 1 + 0.01 * (2 * (np.arange(200) + 0.5) / 200 - 1)
    mc = (mc - lo) / (hi - lo)
    print(f"{len(X)} training runs, {len(val)} validation points\n")
    print("| tool | fit (s) | within max(0.05 pp, 2 %) | largest error (pp) | distribution at one d, 200 samples (ms) |")
    print("|---|---:|---:|---:|---:|")
    for tool in (PodSmt(), PodEgobox(), Ezyrb()):
        try:
            t = time.perf_counter()
            # Each tool gets its own copies: one of them normalises its inputs in place.
            tool.fit(X.copy(), Q.copy())
            fit_s = time.perf_counter() - t
            pred = tool.predict(Xv.copy()).mean(axis=1)
            err = np.abs(pred - truth)
            tool.predict(mc.copy())
            n, t = 0, time.perf_counter()
            while time.perf_counter() - t < 1.0:
                tool.predict(mc)
                n += 1
            lat_ms = 1e3 * (time.perf_counter() - t) / n
            print(f"| {tool.name} | {fit_s:.2f} | {np.mean(err <= tol) * 100:.0f} % | {err.max():.4f} | {lat_ms:.2f} |")
        except Exception as e:  # report, do not hide
            print(f"| {tool.name} | failed: {type(e).__name__}: {e} | | | |")
    rom = [p["rom_mean_slip_pct"] for p in val]
    err = np.abs(np.array(rom) - truth)
    rom_bin = Path(__file__).resolve().parents[2] / "target" / "release" / "rom"
    walls = []
    for _ in range(20):
        t = time.perf_counter()
        subprocess.run([str(rom_bin), "predict", "--d", "0.42"], check=True, capture_output=True)
        walls.append(time.perf_counter() - t)
    print(f"| beltwin (this repo; from `rom validate`) | see docs/validation/surrogate.md | {np.mean(err <= tol) * 100:.0f} % | {err.max():.4f} | "
          f"`rom predict --d 0.42` end to end, process start included: {1e3 * np.median(walls):.1f} |")


if __name__ == "__main__":
    main()
