#!/usr/bin/env bash
# The seed paper's side-gap study on the shipped toothed drive (fom/configs/synchronous-arc.toml):
# one 0.3 s run per side gap (0.1, 0.2, 0.3 mm), three in parallel. Writes
# studies/tooth-load/tooth-load-vs-side-gap.csv and studies/tooth-load/tooth-load-vs-angle.svg.
# About 40 s on 2 cores after the build.
#
#   bash studies/tooth-load/run.sh [SEGMENTS [CONFIG]]
#
# SEGMENTS overrides the configuration's segment count (the resolution study), CONFIG another
# toothed drive (the contact-damping study); with either, the outputs go to a temporary folder
# that is printed, so the shipped drive's figures in this folder stay as they are.
set -euo pipefail
cd "$(dirname "$0")/../.."
out=studies/tooth-load
if [ $# -gt 0 ]; then
  out=$(mktemp -d)
fi
cargo run --release -q -p beltwin-rom --example tooth_load_figure -- "$out" "$@"
