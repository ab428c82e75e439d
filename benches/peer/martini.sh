#!/usr/bin/env bash
# dmesh against @mapbox/martini (RTIN terrain mesher) on the same 513 x 513
# height field, in the same run.
#
# Installs @mapbox/martini from the npm registry into a temporary folder,
# times createTile + getMesh(maxError) under node, runs `dmesh mesh` at the
# same tolerance (epsilon = maxError: both bound the vertical error of a
# height field; dmesh's bound holds for every sample), and prints a table.
# Times are medians of RUNS runs (default 7).
#
# Usage: benches/peer/martini.sh            (from the repository root)
set -euo pipefail
cd "$(dirname "$0")/../.."
RUNS=${RUNS:-7}
command -v node >/dev/null || { echo "node is required (apt-get install nodejs)" >&2; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

cargo build --release --quiet --bin dmesh --example write_height_field
target/release/examples/write_height_field "$tmp"
(cd "$tmp" && npm install --silent --no-audit --no-fund @mapbox/martini@0.2 >/dev/null)

cat > "$tmp/martini.mjs" <<'JS'
import fs from 'node:fs';
import Martini from '@mapbox/martini';
const [file, runs, ...errors] = process.argv.slice(2);
// PFM: "Pf\n<w> <h>\n<scale>\n" then little-endian floats, rows bottom to top.
const buf = fs.readFileSync(file);
let pos = 0, lines = [];
while (lines.length < 3) { const nl = buf.indexOf(10, pos); lines.push(buf.toString('latin1', pos, nl)); pos = nl + 1; }
const [w, h] = lines[1].trim().split(/\s+/).map(Number);
const data = new Float32Array(buf.buffer.slice(buf.byteOffset + pos, buf.byteOffset + pos + 4 * w * h));
const terrain = new Float32Array(w * h);
for (let y = 0; y < h; y++) terrain.set(data.subarray((h - 1 - y) * w, (h - y) * w), y * w);
const median = (a) => a.sort((x, y) => x - y)[a.length >> 1];
const martini = new Martini(w);
for (const maxError of errors.map(Number)) {
  const build = [], extract = [];
  let triangles = 0;
  for (let r = 0; r < Number(runs) + 2; r++) {
    const t0 = process.hrtime.bigint();
    const tile = martini.createTile(terrain);
    const t1 = process.hrtime.bigint();
    const mesh = tile.getMesh(maxError);
    const t2 = process.hrtime.bigint();
    triangles = mesh.triangles.length / 3;
    if (r >= 2) { build.push(Number(t1 - t0) / 1e6); extract.push(Number(t2 - t1) / 1e6); }
  }
  console.log(JSON.stringify({ maxError, triangles, build_ms: median(build), extract_ms: median(extract) }));
}
JS

errors="0.5 2 8"
node "$tmp/martini.mjs" "$tmp/height.pfm" "$RUNS" $errors > "$tmp/martini.jsonl"

printf '%-9s | %10s %9s %9s %9s | %10s %9s %9s %9s | %7s %9s\n' \
  "maxError" "martini tri" "build ms" "mesh ms" "total ms" "dmesh tri" "build ms" "mesh ms" "total ms" "speedup" "tri ratio"
for e in $errors; do
  m=$(grep "\"maxError\":$e," "$tmp/martini.jsonl")
  for r in $(seq "$RUNS"); do
    target/release/dmesh mesh --depth "$tmp/height.pfm" --camera "$tmp/camera.json" --epsilon "$e" --segment none --json
  done > "$tmp/dmesh-$e.jsonl"
  M="$m" python3 - "$tmp/dmesh-$e.jsonl" "$e" <<'PY'
import json, os, statistics, sys
m = json.loads(os.environ["M"])
runs = [json.loads(l) for l in open(sys.argv[1])]
b = statistics.median(r["build_ms"] for r in runs)
x = statistics.median(r["extract_ms"] for r in runs)
t = runs[0]["triangles"]
mt = m["build_ms"] + m["extract_ms"]
print(f'{sys.argv[2]:<9} | {m["triangles"]:>11} {m["build_ms"]:>9.2f} {m["extract_ms"]:>9.2f} {mt:>9.2f} | {t:>10} {b:>9.2f} {x:>9.2f} {b + x:>9.2f} | {mt / (b + x):>6.2f}x {t / m["triangles"]:>9.3f}')
PY
done
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), node $(node --version)"
