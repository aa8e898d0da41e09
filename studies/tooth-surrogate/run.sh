#!/usr/bin/env bash
# The tooth-load surrogate's training campaign on the shipped toothed drive
# (fom/configs/synchronous-arc.toml): 40 Latin-hypercube points over side gap, load torque and
# shaft load (the default [tooth] ranges, the shipped model's seed 20241122), then the fit.
# Copies the campaign's design and outcome, points.csv, to
# studies/tooth-surrogate/training-points.csv; the fitted model stays in the scratch folder
# (printed), since the shipped one is artifacts/synchronous-arc-tooth-surrogate.json.
# About 4 minutes on 2 cores after the build.
#
#   bash studies/tooth-surrogate/run.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
cargo build --release --bin rom -q
work=$(mktemp -d)
./target/release/rom train --config fom/configs/synchronous-arc.toml --samples 40 \
  --seed 20241122 --data "$work/data" --model "$work/tooth-surrogate.json"
cp "$work/data/points.csv" studies/tooth-surrogate/training-points.csv.tmp
mv studies/tooth-surrogate/training-points.csv.tmp studies/tooth-surrogate/training-points.csv
echo "model: $work/tooth-surrogate.json; points: studies/tooth-surrogate/training-points.csv"
