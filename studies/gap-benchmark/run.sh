#!/bin/bash
# The gap diagnosis's speed figure (docs/validation/speed.md): a full `rom gap` diagnosis of a
# 10-label data set (the default drive with 1 N m of hidden bearing drag, d 0.4240-0.4165 m, 4 s
# recordings, the default sensor), timed end to end.
# Usage: bash studies/gap-benchmark/run.sh [DIR] (the data set's folder, default /tmp/gap-bench).
set -euo pipefail
cd "$(dirname "$0")/../.."
cargo build --release --bin rom -q
dir=${1:-/tmp/gap-bench}
rm -rf "$dir"
i=0
for d in 0.4240 0.4230 0.4220 0.4210 0.4200 0.4190 0.4180 0.4175 0.4170 0.4165; do
  ./target/release/rom simulate --d "$d" --duration 4 --measurement-out "$dir" --label "L$i" \
    --effect bearing-drag:coulomb_nm=1.0 > /dev/null
  i=$((i + 1))
done
start=$(date +%s%N)
./target/release/rom gap --measured "$dir" | head -12
end=$(date +%s%N)
echo "rom gap on 10 labels: $(( (end - start) / 1000000 )) ms wall"
