#!/usr/bin/env bash
# The model-form confusion matrix of `rom gap` (docs/validation/gap-model-forms.md): data sets
# made by three independent simulators (the full-order model via `rom simulate
# --measurement-out`, the lumped model `tests/src/lumped.rs`, the continuous-belt creep model
# `tests/src/creep.rs`), each catalogue effect at two magnitudes above its detection limit,
# pairs of effects, healthy rows, two noise realisations, recordings of 3-10 s from standstill
# or in steady running; each diagnosed with `rom gap --measured DIR --format json`.
#
#   bash studies/gap-model-forms/run.sh [FILTER]        # FILTER: a regular expression on
#                                                       # "ID TRUTH MAGNITUDES RECORDING"
#   bash studies/gap-model-forms/run.sh --list [FILTER] # the data sets it would make
#   DATA_DIR=DIR bash studies/gap-model-forms/run.sh --collect [FILTER]
#                                # no runs: rows and summary from the reports kept in DIR
#   DATA_DIR=DIR bash studies/gap-model-forms/run.sh --collect --over OLD.csv [FILTER]
#                                # the same, each row of OLD.csv replaced by the one collected
#
# Environment: JOBS=N data sets at a time (default 1; each `rom gap` uses two threads);
# OUT=FILE the CSV (default studies/gap-model-forms/matrix.csv, or subset.csv with a FILTER),
# its summary per simulator beside it (FILE without .csv + -summary.md); DATA_DIR=DIR keeps
# every data set and its gap.json in DIR/ID and reuses a data set found there; MODEL=FILE
# passes `--model FILE` to `rom gap`; TENSION_READING=SHARE gives the creep simulator's runs a
# tension meter's reading of the belt's static tension, SHARE of it its standard deviation.
#
# Full run: 124 data sets (20 of the lumped simulator's left out: it does not model the
# driver's runout, blade pass, Stribeck friction or hysteresis); at 31-60 s per `rom gap` and
# about 40 s of full-order simulation per full-order data set on an idle 2-core machine, about
# 2.5 hours at JOBS=1 (an estimate; docs/validation/gap-model-forms.md).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
cd "$here/../.."
list=()
if [ "${1:-}" = "--list" ] || [ "${1:-}" = "--collect" ]; then list=("$1"); shift; fi
if [ "${1:-}" = "--over" ]; then list+=("$1" "$2"); shift 2; fi
filter=${1:-}
cargo build --release --bin rom -q
cargo build --release -p beltwin-tests --example lumped --example creep -q
target=${CARGO_TARGET_DIR:-target}
# Copies of the binaries, so that a rebuild during the run does not change them midway.
bin=$(mktemp -d)
trap 'rm -rf "$bin"' EXIT
cp "$target/release/rom" "$target/release/examples/lumped" "$target/release/examples/creep" "$bin/"
if [ -n "$filter" ]; then default_out=$here/subset.csv; else default_out=$here/matrix.csv; fi
out=${OUT:-$default_out}
exec python3 "$here/matrix.py" "${list[@]}" --rom "$bin/rom" --lumped "$bin/lumped" \
  --creep "$bin/creep" --out "$out" ${filter:+-- "$filter"}
