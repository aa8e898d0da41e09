#!/usr/bin/env bash
# The twin calibrated to the seed paper's Table 2 (tests/data/paper-table2-mean-slip.csv: five
# mean slips, d0 to d4) with the shipped surrogate, confirmed by the full-order model. Writes the
# calibrated drive configuration to studies/table2-calibration/table2-calibrated.toml and prints
# the calibration report. About 30 s on 2 cores after the build (one full-order confirmation).
#
#   bash studies/table2-calibration/run.sh [--leave-one-out]   # that flag: a few minutes more
set -euo pipefail
cd "$(dirname "$0")/../.."
cargo build --release --bin rom -q
./target/release/rom calibrate --table tests/data/paper-table2-mean-slip.csv \
  --free friction,tension,ratio,spaced-distances --tolerance 2 \
  --out studies/table2-calibration/table2-calibrated.toml "$@"
