#!/usr/bin/env bash
# One run, same machine: Exudyn (ANCF, 60 elements) and beltwin (240 segments) on the same drive
# for the same simulated time. Usage: bash artifacts/field/exudyn_vs_beltwin.sh [END_TIME_S]
set -euo pipefail
cd "$(dirname "$0")/../.."
T=${1:-0.25}
cargo build --release -q --bin rom
python3 artifacts/field/exudyn_belt.py 60 "$T" 2>/dev/null | grep '^exudyn'
/usr/bin/time -f "beltwin 240 segments, $T s: wall %e s (process)" \
  ./target/release/rom simulate --config artifacts/field/exudyn-comparison.toml \
  --duration "$T" --out /tmp/beltwin-exudyn-case.csv | grep -E 'wall time'
