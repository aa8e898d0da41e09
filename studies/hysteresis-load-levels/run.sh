#!/usr/bin/env bash
# Two load levels in `rom gap`: data sets of the model-form matrix's four labels (d 0.424,
# 0.421, 0.418, 0.416 m, 5 s from standstill, the fan law of fom/configs/hvac.toml) plus d0 and
# d2 again with the fan throttled to 0.6 of its coefficient (labels d0-low, d2-low, their
# manifest giving `load_torque_nm`, the fan law's torque at the recording's mean fan speed over
# its last 2 s), diagnosed by the shipped twin (EA 20 kN):
#   healthy         full-order model, no effect
#   hysteresis      full-order model, belt hysteresis g 0.2, tau 10 ms
#   softer          full-order model, no hysteresis, EA 16 kN (the same relaxed stiffness)
#   lumped          the lumped simulator's healthy belt (creep stiffness factor 1.15, as in the
#                   model-form matrix)
#   creep           the continuous-belt creep simulator's healthy belt (its counter sensor)
# Prints, per data set, the verdict, and the load levels' pairs and fit.
#
#   bash studies/hysteresis-load-levels/run.sh [DIR] [CASE...]   # DIR keeps the data sets
#                                                                # (default: a temporary folder)
# About 5 minutes on 2 cores.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
cd "$here/../.."
cargo build --release --bin rom -q
cargo build --release -p beltwin-tests --example lumped --example creep -q
target_dir=${CARGO_TARGET_DIR:-target}
rom=$target_dir/release/rom
if [ -n "${1:-}" ]; then
  work=$1
  shift
  mkdir -p "$work"
else
  work=$(mktemp -d)
  trap 'rm -rf "$work"' EXIT
fi
base=fom/configs/hvac.toml
low() { sed 's/^fan_nm_s2 = 1.69e-3/fan_nm_s2 = 1.014e-3/' "$1"; }
soft() { sed 's/^axial_stiffness_n = 20000.0/axial_stiffness_n = 16000.0/' "$1"; }
low "$base" >"$work/low.toml"
soft "$base" >"$work/soft.toml"
soft "$work/low.toml" >"$work/soft-low.toml"
grep -q '^fan_nm_s2 = 1.014e-3' "$work/low.toml"
grep -q '^axial_stiffness_n = 16000.0' "$work/soft-low.toml"
python3 - "$target_dir" "$work" "$@" <<'PY'
import csv, json, math, os, shutil, sys, tomllib

target, work, only = sys.argv[1], sys.argv[2], sys.argv[3:]
rom = os.path.join(target, "release", "rom")
example = lambda name: os.path.join(target, "release", "examples", name)
sys.path.insert(0, "studies/gap-model-forms")
import matrix  # noqa: E402  (the matrix's labels, recordings and data-set maker)

HYST = "belt-hysteresis:stiffness_ratio=0.2,relaxation_s=0.01"
CASES = {
    "healthy": ("fom", [], None, "low.toml"),
    "hysteresis": ("fom", [HYST], None, "low.toml"),
    "softer": ("fom", [], "soft.toml", "soft-low.toml"),
    "lumped": ("lumped", ["--creep", matrix.LUMPED_CREEP], None, None),
    "creep": ("creep", [], None, None),
}
THROTTLE = 0.6
FAN_CONSTANT_NM, FAN_LOW_NM_S2 = 0.2, THROTTLE * 1.69e-3


def steady_torque_nm(path):
    """The throttled fan's torque at the recording's mean fan speed over its last 2 s."""
    rows = [r for r in csv.DictReader(l for l in open(path) if not l.startswith("#"))]
    end = float(rows[-1]["time_s"])
    n = [float(r["driven_rpm"]) for r in rows if float(r["time_s"]) >= end - 2.0]
    w = sum(n) / len(n) * math.pi / 30.0
    return FAN_CONSTANT_NM + FAN_LOW_NM_S2 * w * w


def make(sim, specs, cfg, labels, seed, throttled, out, cfg_low):
    if sim == "fom":
        saved, matrix.LABELS = matrix.LABELS, labels
        args = ["--config", os.path.join(work, cfg_low if throttled else cfg)] \
            if (cfg_low if throttled else cfg) else []
        matrix.make_fom({"id": os.path.basename(out), "kind": matrix.STANDSTILL_5S,
                         "seed": seed, "specs": specs, "args": args}, out, {"rom": rom}, work)
        matrix.LABELS = saved
    else:
        cmd = [example(sim), out, "--labels", ",".join(f"{l}={d}" for l, d in labels),
               "--seed", str(seed), "--duration", "5"] + specs
        matrix.run(cmd + (["--fan-scale", str(THROTTLE)] if throttled else []))


for name, (sim, specs, cfg, cfg_low) in CASES.items():
    if only and name not in only:
        continue
    out = os.path.join(work, name)
    if not os.path.exists(os.path.join(out, "manifest.toml")):
        shutil.rmtree(out, ignore_errors=True)
        low = out + "-low"
        shutil.rmtree(low, ignore_errors=True)
        make(sim, specs, cfg, matrix.LABELS, 11300, False, out, cfg_low)
        make(sim, specs, cfg, [("d0-low", 0.424), ("d2-low", 0.418)], 11350, True, low, cfg_low)
        with open(os.path.join(out, "manifest.toml"), "rb") as f:
            m = tomllib.load(f)
        with open(os.path.join(low, "manifest.toml"), "rb") as f:
            m_low = tomllib.load(f)
        for r in m_low["run"]:
            shutil.copy(os.path.join(low, r["file"]), out)
            r["load_torque_nm"] = round(steady_torque_nm(os.path.join(low, r["file"])), 3)
        m["run"] += m_low["run"]
        matrix.write_manifest(os.path.join(out, "manifest.toml"), m)
        shutil.rmtree(low)
    rep = json.loads(matrix.run([rom, "gap", "--measured", out, "--format", "json"]))
    ll = rep["load_levels"]
    print(f"{name}: verdict {rep['top_effect']}, withheld RMS z {rep['gap_before']['rms_z']:.2f}, "
          f"{rep['elapsed_s']:.0f} s")
    for p in ll["pairs"]:
        print(f"  {p['label']} against {p['partner']}: load {p['load_torque_nm'][0]:.2f} -> "
              f"{p['load_torque_nm'][1]:.2f} N m, rise measured {p['measured_rise_pct']:+.4f} "
              f"(sd {p['rise_sd_pct']:.4f}), twin {p['twin_rise_pct']:+.4f}, per g "
              f"{p['twin_rise_per_g_pct']:+.4f} pp; z {p['z_before']:+.1f} -> {p['z_after']:+.1f}")
    f = ll.get("fit")
    if f:
        g, (glo, ghi) = f["stiffness_ratio"], f["stiffness_ratio_interval90"]
        ea, (elo, ehi) = f["equivalent_axial_stiffness_n"], f["equivalent_axial_stiffness_interval90_n"]
        print(f"  g {g:.3f} [{glo:.3f}, {ghi:.3f}], rise ratio {f['rise_ratio']:.3f}, EA "
              f"{ea:.0f} [{elo:.0f}, {ehi:.0f}] N, score {f['score']:.1f}, RMS z "
              f"{f['rms_z_before']:.2f} -> {f['rms_z_after']:.2f}")
    h = next(r for r in rep["ranking"] if r["effect"] == "belt-hysteresis")
    print(f"  ranking: belt-hysteresis score {h['score']:.1f}, g {h['params'][0]['value']:.3f}")
    print(f"  {ll['finding']}")
PY
