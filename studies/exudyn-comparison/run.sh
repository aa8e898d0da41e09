#!/usr/bin/env bash
# One run, same machine: Exudyn (ANCF, 60 elements) and beltwin (240 segments) on the same drive
# for the same simulated time; the mean slip of each over the last 40 % of the run beside creep
# theory (EA + T_slack) / (EA + T_tight) from beltwin's span tensions over the same window.
# Usage: bash studies/exudyn-comparison/run.sh [END_TIME_S]   (needs python3 with exudyn)
set -euo pipefail
cd "$(dirname "$0")/../.."
T=${1:-0.25}
cargo build --release -q --bin rom
python3 studies/exudyn-comparison/exudyn_belt.py 60 "$T" 2>/dev/null | grep '^exudyn'
/usr/bin/time -f "beltwin 240 segments, $T s: wall %e s (process)" \
  ./target/release/rom simulate --config studies/exudyn-comparison/exudyn-comparison.toml \
  --duration "$T" --out /tmp/beltwin-exudyn-case.csv | grep -E 'wall time'
python3 - "$T" <<'PY'
import csv, sys
t_end = float(sys.argv[1])
ea = 20000.0  # EA of studies/exudyn-comparison/exudyn-comparison.toml
rows = [r for r in csv.DictReader(open("/tmp/beltwin-exudyn-case.csv"))
        if float(r["time_s"]) > 0.6 * t_end and r["slip_pct"]]
mean = lambda k: sum(float(r[k]) for r in rows) / len(rows)
theory = 100 * (1 - (ea + mean("slack_span_tension_n")) / (ea + mean("tight_span_tension_n")))
print(f"beltwin mean slip {mean('slip_pct'):.4f} % (t > {0.6 * t_end:.2f} s); creep theory from "
      f"its span tensions {theory:.4f} %")
PY
