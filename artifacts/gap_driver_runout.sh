#!/usr/bin/env bash
# Driver-pulley runout near the knee (issue 11, README "`rom gap`"): the 1x driver line in the
# driver speed (steady part, t > 2 s, least squares with a linear trend) of single full-order
# runs: at d 0.424 m and 0.25 mm on the default drive (240 segments) and at the gap's reduced
# resolution (120 segments, 2e-5 s); at d 0.416 m, reduced resolution, 0.25 and 0.5 mm at
# mu 0.7 / 250 N, and 0.5 mm at the calibrated mu 0.6675 / 240.2 N of a gap run. About 2
# minutes on 2 cores.
#
#   bash artifacts/gap_driver_runout.sh
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --bin rom -q
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
rom=target/release/rom
sed -e 's/^step_s = 1.0e-5/step_s = 2.0e-5/' -e 's/^segments = 240/segments = 120/' \
  fom/configs/hvac.toml >"$work/reduced.toml"
grep -q '^segments = 120' "$work/reduced.toml" || { echo "hvac.toml changed: update the sed" >&2; exit 1; }
ecc() { echo "pulley-eccentricity:pulley=driver,runout_m=$1"; }
"$rom" simulate --d 0.424 --duration 3 --effect "$(ecc 0.00025)" --out "$work/full-0.424-0.25.csv" >/dev/null 2>&1 &
"$rom" simulate --config "$work/reduced.toml" --d 0.424 --duration 3 --effect "$(ecc 0.00025)" \
  --out "$work/reduced-0.424-0.25.csv" >/dev/null 2>&1
wait
"$rom" simulate --config "$work/reduced.toml" --d 0.416 --duration 3.5 --effect "$(ecc 0.00025)" \
  --out "$work/reduced-0.416-0.25.csv" >/dev/null 2>&1 &
"$rom" simulate --config "$work/reduced.toml" --d 0.416 --duration 3.5 --effect "$(ecc 0.0005)" \
  --out "$work/reduced-0.416-0.5.csv" >/dev/null 2>&1
wait
"$rom" simulate --config "$work/reduced.toml" --d 0.416 --mu 0.6675 --tension 240.2 --duration 3.5 \
  --effect "$(ecc 0.0005)" --out "$work/reduced-0.416-0.5-calibrated.csv" >/dev/null 2>&1
python3 - "$work"/*.csv <<'PY'
import csv, math, os, sys

def lstsq(cols, y):
    k = len(cols)
    a = [[sum(p * q for p, q in zip(cols[i], cols[j])) for j in range(k)] for i in range(k)]
    b = [sum(p * q for p, q in zip(cols[i], y)) for i in range(k)]
    for c in range(k):
        piv = max(range(c, k), key=lambda r: abs(a[r][c]))
        a[c], a[piv], b[c], b[piv] = a[piv], a[c], b[piv], b[c]
        for r in range(c + 1, k):
            f = a[r][c] / a[c][c]
            a[r] = [x - f * z for x, z in zip(a[r], a[c])]
            b[r] -= f * b[c]
    x = [0.0] * k
    for c in reversed(range(k)):
        x[c] = (b[c] - sum(a[c][j] * x[j] for j in range(c + 1, k))) / a[c][c]
    return x

for path in sys.argv[1:]:
    rows = [r for r in csv.DictReader(open(path)) if float(r["time_s"]) > 2.0]
    t = [float(r["time_s"]) for r in rows]
    n1 = [float(r["driver_rpm"]) for r in rows]
    f1 = sum(n1) / len(n1) / 60
    w = 2 * math.pi * f1
    x = lstsq([[1.0] * len(t), t, [math.cos(w * s) for s in t], [math.sin(w * s) for s in t]], n1)
    print(f"{os.path.basename(path)[:-4]:32s} 1x driver line {math.hypot(x[2], x[3]):.2f} rpm")
PY
