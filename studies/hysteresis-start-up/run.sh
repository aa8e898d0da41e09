#!/usr/bin/env bash
# Belt hysteresis against a softer belt in `rom gap`: two full-order data sets with the same
# relaxed axial stiffness, four labels of 5 s from standstill (d 0.424, 0.421, 0.418,
# 0.416 m; the noise seeds of the model-form matrix's row fom-r1-13), diagnosed by the shipped
# twin (EA 20 kN):
#   hysteresis  belt hysteresis g 0.2, tau 10 ms (relaxed stiffness 0.8 EA = 16 kN)
#   softer      no hysteresis, EA 16 kN
# Prints, per data set, the verdict, the calibrated slip offset and the withheld z of every
# label's steady and start-up slip level, and the hysteresis candidate's scores and fit.
#
#   bash studies/hysteresis-start-up/run.sh [DIR]   # DIR keeps the data sets (default: a
#                                                   # temporary folder)
# About 3 minutes on 2 cores.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
cd "$here/../.."
cargo build --release --bin rom -q
rom=${CARGO_TARGET_DIR:-target}/release/rom
if [ -n "${1:-}" ]; then
  work=$1
  mkdir -p "$work"
else
  work=$(mktemp -d)
  trap 'rm -rf "$work"' EXIT
fi
sed 's/^axial_stiffness_n = 20000.0/axial_stiffness_n = 16000.0/' fom/configs/hvac.toml \
  >"$work/softer.toml"
grep -q '^axial_stiffness_n = 16000.0' "$work/softer.toml"
python3 - "$rom" "$work" <<'PY'
import json, os, shutil, sys

rom, work = sys.argv[1], sys.argv[2]
sys.path.insert(0, "studies/gap-model-forms")
import matrix  # noqa: E402  (the matrix's labels, recordings and data-set maker)

# fom-r1-13's noise seeds: 100 k + 10000 realisation, k = 13, realisation 1.
CASES = {
    "hysteresis": {"specs": ["belt-hysteresis:stiffness_ratio=0.2,relaxation_s=0.01"]},
    "softer": {"specs": [], "args": ["--config", os.path.join(work, "softer.toml")]},
}
for name, case in CASES.items():
    out = os.path.join(work, name)
    if not os.path.exists(os.path.join(out, "manifest.toml")):
        shutil.rmtree(out, ignore_errors=True)
        matrix.make_fom({"id": name, "kind": matrix.STANDSTILL_5S, "seed": 11300, **case}, out,
                        {"rom": rom}, work)
    rep = json.loads(matrix.run([rom, "gap", "--measured", out, "--format", "json"]))
    cal = rep["calibration"]
    print(f"{name}: verdict {rep['top_effect']}, withheld RMS z {rep['gap_before']['rms_z']:.2f}, "
          f"slip offset {cal['slip_offset_pct']:+.3f} pp, friction {cal['friction']:.3f}, "
          f"tension {cal['installation_tension_n']:.1f} N")
    for c in rep["where"]:
        if c["cell"].endswith("slip/mean/level"):
            print(f"  {c['label']} {c['cell']:<26} z {c['z']:+.1f}")
    h = next(r for r in rep["ranking"] if r["effect"] == "belt-hysteresis")
    p = h["params"][0]
    print(f"  belt-hysteresis: score {h['score']:.1f}, beyond the slip level "
          f"{h['score_beyond_slip_level']:.1f}, {p['name']} {p['value']:.3f} "
          f"[{p['interval90'][0]:.3f}, {p['interval90'][1]:.3f}]")
PY
