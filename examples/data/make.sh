#!/usr/bin/env bash
# Re-make the three sample data sets of examples/data/ with the project's own full-order model.
# Each recording is a synthetic measurement in the exchange format belt-measurements/1
# (docs/measured-data.md): the default HVAC drive (fom/configs/hvac.toml) read through two
# 60-pulse tachometers at 500 Hz with 1 rpm of speed noise.
#
#   bash examples/data/make.sh                              # from the workspace root
#   ROM=/path/to/rom bash examples/data/make.sh             # with an already built binary
#
# Takes about two minutes on two cores. The full-order model is deterministic, so the files
# come out the same on every run with the same binary.
set -euo pipefail
cd "$(dirname "$0")"
ROM=${ROM:-"cargo run --release --quiet --bin rom --"}
RATE=500
# The full-order time series (--out) is not part of the data set: it goes to a scratch folder.
# (Never point --out at /dev/null: the file is written to a temporary file and renamed.)
SCRATCH=$(mktemp -d)
trap 'rm -rf "$SCRATCH"' EXIT

# record SET LABEL D DURATION_S SEED [extra rom simulate flags...]
record() {
    local set=$1 label=$2 d=$3 duration=$4 seed=$5
    shift 5
    $ROM simulate --d "$d" --duration "$duration" --out "$SCRATCH/run.csv" \
        --measurement-out "$set" --label "$label" --sample-rate "$RATE" --noise-seed "$seed" "$@" \
        > "$SCRATCH/summary.txt"
}

rm -rf healthy loose effect

# healthy/: the belt as installed (250 N at 0.42 m), from tight to slightly loose; all healthy.
# 4-5 s recordings: the start-up takes about 1.5 s and a diagnosis needs 1 s of steady running
# (docs/decisions/steady-window.md).
record healthy d0 0.4240 5 1
record healthy d1 0.4210 5 2
record healthy d2 0.4185 5 3
record healthy d3 0.4165 5 4

# loose/: a belt that has lost tension (180 N at 0.42 m). d0-d2 are still healthy; at d3 the
# belt is loose and slips. A loose belt settles later (about 4 s), so its recording is longer.
record loose d0 0.4240 4 11 --tension 180
record loose d1 0.4200 4 12 --tension 180
record loose d2 0.4170 4 13 --tension 180
record loose d3 0.4165 6 14 --tension 180

# effect/: the healthy drive with an effect the twin does not model: 0.5 N m of Coulomb drag
# in the fan bearings.
for args in "d0 0.4240 3 21" "d1 0.4210 3 22" "d2 0.4185 3 23" "d3 0.4165 3 24"; do
    # shellcheck disable=SC2086
    record effect $args --effect bearing-drag:coulomb_nm=0.5
done
