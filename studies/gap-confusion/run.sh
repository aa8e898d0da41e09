#!/usr/bin/env bash
# Confusion matrix of `rom gap`: for every catalogue effect at several magnitudes,
# a data set made by the full-order model with that effect on (default drive, four labels at
# d 0.424, 0.421, 0.418, 0.416 m, 4 s from standstill, 60-pulse tachometers with 1 rpm noise, a
# fresh noise seed per recording), then `rom gap --measured DIR --format json` (leave one label
# out). Writes studies/gap-confusion/gap_confusion.csv (one row per data set; with NOISE_OFFSET=K,
# gap_confusion-noiseK.csv; OUT=FILE names another) and prints it.
#
#   bash studies/gap-confusion/run.sh [ROWS_FILTER]     # e.g. `drag` to run only matching rows
#
# ROWS_FILTER is a bash regular expression matched against "NAME MAGNITUDE" (a plain word
# matches as a substring); with it the rows are printed, not written to the CSV.
#
# Environment: DATA_DIR=DIR keeps each data set in DIR/setN and reuses one found there (the
# same recordings diagnosed by another build or model); MODEL=FILE passes `--model FILE`;
# NOISE_OFFSET=K (default 0) adds K to every noise seed (the full-order rows' sensors and the
# lumped simulator's seed): another realisation of the same matrix, with its own DATA_DIR.
#
# About 75 s per data set on 2 cores; the full matrix (36 data sets) about 40 minutes.
set -euo pipefail
cd "$(dirname "$0")/../.."
cargo build --release --bin rom -q
cargo build --release -p beltwin-tests --example lumped -q
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# A copy of the binary, so that a rebuild during the half hour does not change it midway.
target=${CARGO_TARGET_DIR:-target}
cp "$target/release/rom" "$work/rom"
cp "$target/release/examples/lumped" "$work/lumped"
rom=$work/rom
offset=${NOISE_OFFSET:-0}
if [ "$offset" = 0 ]; then
  out=${OUT:-studies/gap-confusion/gap_confusion.csv}
else
  out=${OUT:-studies/gap-confusion/gap_confusion-noise$offset.csv}
fi
filter=${1:-}
# One run at a time (two would interleave their rows).
exec 9>"$out.lock"
flock -n 9 || { echo "another studies/gap-confusion/run.sh is running" >&2; exit 1; }

# name | effect spec ("" for none) | extra sensor flags | magnitude shown
cases=(
  "none||-|0"
  "bearing-drag|bearing-drag:coulomb_nm=0.1|-|0.1 N m"
  "bearing-drag|bearing-drag:coulomb_nm=0.3|-|0.3 N m"
  "bearing-drag|bearing-drag:coulomb_nm=1.0|-|1.0 N m"
  "pulley-eccentricity (driven)|pulley-eccentricity:pulley=driven,runout_m=0.00025|-|0.25 mm"
  "pulley-eccentricity (driven)|pulley-eccentricity:pulley=driven,runout_m=0.0005|-|0.5 mm"
  "pulley-eccentricity (driven)|pulley-eccentricity:pulley=driven,runout_m=0.001|-|1.0 mm"
  "pulley-eccentricity (driver)|pulley-eccentricity:pulley=driver,runout_m=0.0001|-|0.1 mm"
  "pulley-eccentricity (driver)|pulley-eccentricity:pulley=driver,runout_m=0.00025|-|0.25 mm"
  "pulley-eccentricity (driver)|pulley-eccentricity:pulley=driver,runout_m=0.0005|-|0.5 mm"
  "blade-pass-pulsation|blade-pass-pulsation:blades=8,amplitude=0.1|-|z 8, a 0.1"
  "blade-pass-pulsation|blade-pass-pulsation:blades=8,amplitude=0.2|-|z 8, a 0.2"
  "blade-pass-pulsation|blade-pass-pulsation:blades=8,amplitude=0.4|-|z 8, a 0.4"
  "stribeck-friction|stribeck-friction:dynamic_ratio=0.8,stribeck_speed_m_s=0.05|-|1-mu_d/mu_s 0.2"
  "stribeck-friction|stribeck-friction:dynamic_ratio=0.6,stribeck_speed_m_s=0.05|-|1-mu_d/mu_s 0.4"
  "stribeck-friction|stribeck-friction:dynamic_ratio=0.4,stribeck_speed_m_s=0.05|-|1-mu_d/mu_s 0.6"
  "belt-hysteresis|belt-hysteresis:stiffness_ratio=0.03,relaxation_s=0.01|-|g 0.03"
  "belt-hysteresis|belt-hysteresis:stiffness_ratio=0.1,relaxation_s=0.01|-|g 0.1"
  "belt-hysteresis|belt-hysteresis:stiffness_ratio=0.2,relaxation_s=0.01|-|g 0.2"
  "tachometer||--timer-resolution 1e-6|timer 1 us"
  "tachometer||--timer-resolution 2e-6|timer 2 us"
  "tachometer||--timer-resolution 5e-6|timer 5 us"
  # Another simulator: the lumped-parameter model of tests/src/lumped.rs (a saturating
  # traction curve on two shafts; creep 15 % stiffer than EA, so its healthy slip and its knee
  # differ from the full-order model's), written with the same sensor.
  "other simulator: none|LUMPED:--creep 1.15|-|0"
  "other simulator: bearing-drag|LUMPED:--creep 1.15 --drag 1.5|-|1.5 N m"
  "other simulator: none (steady-start recordings)|LUMPED:--creep 1.15 --duration 6 --from 3|-|0"
  # Its fan pulley eccentric (the belt's moment arm r2 + e cos(theta2)) and its tachometer timer.
  "other simulator: pulley-eccentricity (driven)|LUMPED:--creep 1.15 --runout 0.0005|-|0.5 mm"
  "other simulator: pulley-eccentricity (driven)|LUMPED:--creep 1.15 --runout 0.001|-|1.0 mm"
  "other simulator: tachometer|LUMPED:--creep 1.15 --timer-resolution 2e-6|-|timer 2 us"
  "other simulator: tachometer|LUMPED:--creep 1.15 --timer-resolution 5e-6|-|timer 5 us"
  # Added later, after the rows above so that their noise seeds,
  # which follow the row number, stay as they were: the upper ends of the detectable ranges
  # that the ignored tests in tests/tests/gap.rs draw from.
  "bearing-drag|bearing-drag:coulomb_nm=3.0|-|3.0 N m"
  "pulley-eccentricity (driven)|pulley-eccentricity:pulley=driven,runout_m=0.0015|-|1.5 mm"
  "pulley-eccentricity (driven)|pulley-eccentricity:pulley=driven,runout_m=0.002|-|2.0 mm"
  "belt-hysteresis|belt-hysteresis:stiffness_ratio=0.3,relaxation_s=0.01|-|g 0.3"
  "belt-hysteresis|belt-hysteresis:stiffness_ratio=0.4,relaxation_s=0.01|-|g 0.4"
  "tachometer||--timer-resolution 3e-6|timer 3 us"
  "tachometer||--timer-resolution 4e-6|timer 4 us"
)
labels=("d0 0.4240" "d1 0.4210" "d2 0.4180" "d3 0.4160")

[ -n "$filter" ] || echo "hidden effect,magnitude,top effect,score,fitted,withheld rms z before,after,reduction,wall s,knee labels left out,sensor read" >"$out.tmp"
[ -z "$filter" ] || : >"$out.tmp"
n=0
for case in "${cases[@]}"; do
  IFS='|' read -r name spec sensor mag <<<"$case"
  n=$((n + 1))
  [[ -z "$filter" || "$name $mag" =~ $filter ]] || continue
  dir="${DATA_DIR:-$work}/set$n"
  k=0
  if [ -f "$dir/manifest.toml" ]; then
    : # reused (DATA_DIR)
  elif [[ "$spec" == LUMPED:* ]]; then
    lumped_labels=$(for pair in "${labels[@]}"; do read -r l d <<<"$pair"; printf '%s=%s,' "$l" "$d"; done)
    # shellcheck disable=SC2086
    "$work/lumped" "$dir" --labels "${lumped_labels%,}" --seed $((n + $offset)) ${spec#LUMPED:} >/dev/null
  else
  for pair in "${labels[@]}"; do
    read -r label d <<<"$pair"
    args=(simulate --d "$d" --duration 4 --label "$label"
      --noise-seed $((100 * n + k + $offset)))
    [ -z "$spec" ] || args+=(--effect "$spec")
    [ "$sensor" = "-" ] || args+=($sensor)
    # Two runs at a time (2 cores); the manifest is appended in label order below.
    "$rom" "${args[@]}" --measurement-out "$work/part$n-$k" >/dev/null &
    k=$((k + 1))
    if [ $((k % 2)) -eq 0 ]; then wait; fi
  done
  wait
  # Merge the per-label data sets into one (manifest entries in label order).
  mkdir -p "$dir"
  head -n 4 "$work/part$n-0/manifest.toml" >"$dir/manifest.toml"
  for k in 0 1 2 3; do
    cp "$work/part$n-$k"/*.csv "$dir/"
    tail -n +5 "$work/part$n-$k/manifest.toml" >>"$dir/manifest.toml"
  done
  fi
  start=$(date +%s.%N)
  model_args=()
  [ -z "${MODEL:-}" ] || model_args=(--model "$MODEL")
  "$rom" gap --measured "$dir" "${model_args[@]}" --format json >"$work/gap$n.json"
  end=$(date +%s.%N)
  [ -z "${DATA_DIR:-}" ] || cp "$work/gap$n.json" "$DATA_DIR/gap$n.$(basename "${MODEL:-shipped}" .json).json"
  python3 - "$work/gap$n.json" "$name" "$mag" "$start" "$end" >>"$out.tmp" <<'EOF'
import json, sys


def sensor_read(report):
    """The tachometer the sensor stage read from the readings before judging the mechanics
    (a pulse timer from their lattice, or a speed counter), as the twin then reads itself;
    empty where it read none."""
    s = report.get("sensor") or {}
    if s.get("counter") and s.get("twin_gate_s"):
        return f"counter gate {1e3 * s['twin_gate_s']:.1f} ms"
    if s.get("pulses_x_timer_s") is not None:
        return f"timer {1e6 * s['twin_timer_resolution_s']:.1f} us"
    return ""


r = json.load(open(sys.argv[1]))
top = r["ranking"][0]
fitted = "; ".join(
    f"{p['name']} {p['value']:.4g}"
    + (f" [{p['interval90'][0]:.4g}, {p['interval90'][1]:.4g}]" if p["interval90"][0] is not None else "")
    for p in top["params"])
after = r["gap_after"]["rms_z"] if r.get("gap_after") else ""
after = f"{after:.2f}" if after != "" else ""
top_name = r["top_effect"]
if top_name == "none" or top_name == "unexplained":
    top_name += f" (first: {top['effect']})"
elif r.get("not_told_apart_from"):
    top_name += f" (not told apart from {r['not_told_apart_from']})"
print(f"{sys.argv[2]},\"{sys.argv[3]}\",{top_name},{top['score']:.1f},\"{fitted}\","
      f"{r['gap_before']['rms_z']:.2f},{after},{r['reduction'] if r['reduction'] is not None else ''},"
      f"{float(sys.argv[5]) - float(sys.argv[4]):.0f},"
      + " ".join(k["label"] for k in r.get("knee_labels", [])) + "," + sensor_read(r))
EOF
  tail -n 1 "$out.tmp"
done
if [ -z "$filter" ]; then mv "$out.tmp" "$out"; else rm "$out.tmp"; fi
