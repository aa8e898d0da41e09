#!/usr/bin/env bash
# Model-form check of `rom gap`: a data set of the default drive without any effect
# (four labels at d 0.424, 0.421, 0.418, 0.416 m, 4 s, the default sensor, noise seed 1), then
# the same data with label-dependent slip added, a knee of another shape than the model's
# (another simulator's): "0,0.01,0.04,0.1" pp and "0,0.03,0.12,0.3" pp from d0 to d3. Prints
# each verdict's first lines. About 3 minutes on 2 cores.
#
#   bash studies/gap-added-slip/run.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
cargo build --release --bin rom -q
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cp target/release/rom "$work/rom"
for pair in "d0 0.4240" "d1 0.4210" "d2 0.4180" "d3 0.4160"; do
  read -r label d <<<"$pair"
  "$work/rom" simulate --d "$d" --duration 4 --measurement-out "$work/null" --label "$label" >/dev/null
done
for added in 0,0.01,0.04,0.1 0,0.03,0.12,0.3; do
  # Each label's driven speed lowered so that its slip rises by the given pp (R_t = 2 on the
  # default drive; running samples only), the recordings otherwise unchanged.
  python3 - "$work/null" "$work/mf" "$added" <<'PY'
import csv, os, shutil, sys
src, dst, added = sys.argv[1], sys.argv[2], [float(x) for x in sys.argv[3].split(",")]
shutil.rmtree(dst, ignore_errors=True)
os.makedirs(dst)
shutil.copy(os.path.join(src, "manifest.toml"), dst)
ratio = 2.0
for k, ds in enumerate(added):
    name = f"d{k}-run1.csv"
    lines = open(os.path.join(src, name)).read().splitlines()
    head = [l for l in lines if l.startswith("#")]
    rows = list(csv.reader([l for l in lines if not l.startswith("#")]))
    with open(os.path.join(dst, name), "w") as out:
        out.write("\n".join(head) + "\n" + ",".join(rows[0]) + "\n")
        for t, n1, n2 in ([float(x) for x in r] for r in rows[1:]):
            if n1 > 100:
                n2 -= n1 * ds / (100 * ratio)
            out.write(f"{t:.6f},{n1:.3f},{n2:.3f}\n")
PY
  echo "== slip added per label (pp): $added"
  "$work/rom" gap --measured "$work/mf" | sed -n '1p;6,9p'
done
