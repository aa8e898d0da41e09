#!/usr/bin/env bash
# Instruction counts (valgrind callgrind: repeatable, unlike wall time on a shared machine) of
# 0.3 s of the default drive from standstill with each catalogue effect, against none.
# Usage: bash studies/effect-cost/run.sh   (after cargo build --release; about 3 minutes)
set -euo pipefail
cd "$(dirname "$0")/../.."
rom=./target/release/rom
count() {
  local out
  out=$(mktemp -d)
  valgrind --tool=callgrind --callgrind-out-file="$out/cg" "$rom" simulate --duration 0.3 \
    --out "$out/run.csv" "$@" >/dev/null 2>"$out/log"
  grep -E "Collected" "$out/log" | awk '{print $NF}'
  rm -rf "$out"
}
base=$(count)
printf '%-22s %16s %8s\n' effect instructions "vs none"
printf '%-22s %16s %8s\n' none "$base" "+0.0 %"
for spec in "pulley-eccentricity:pulley=driven,runout_m=2e-4" \
            "blade-pass-pulsation:blades=8,amplitude=0.05" \
            "stribeck-friction:dynamic_ratio=0.6,stribeck_speed_m_s=0.05" \
            "bearing-drag:coulomb_nm=1" \
            "belt-hysteresis:stiffness_ratio=0.2,relaxation_s=0.01"; do
  n=$(count --effect "$spec")
  printf '%-22s %16s %+7.1f %%\n' "${spec%%:*}" "$n" "$(echo "100 * ($n / $base - 1)" | bc -l)"
done
