#!/usr/bin/env bash
# Convergence of the default drive's steady mean slip and span tensions with segment count and
# time step, beside creep theory from the run's own span tensions (3 s from standstill per
# case: 60, 120, 240 and 480 segments, steps 1e-5 down to 2.5e-6 s). Writes the table to
# studies/fom-convergence/fom-convergence.md. About 1 minute on one core after the build.
#
#   bash studies/fom-convergence/run.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
out=studies/fom-convergence/fom-convergence.md
cargo run --release -q -p beltwin-fom --example convergence >"$out.tmp"
mv "$out.tmp" "$out"
