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
# Usage: engine/benches/peer/martini.sh            (from the repository root)
set -euo pipefail
cd "$(dirname "$0")/../../.."
RUNS=${RUNS:-7}
command -v node >/dev/null || { echo "node is required (apt-get install nodejs)" >&2; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

cargo build --release --quiet --bin dmesh
cargo build --release --quiet -p dmesh-engine --example write_height_field
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
    if (r === 0) var last = mesh;
  }
  // The largest vertical deviation of any sample from martini's mesh: the
  // bound martini actually delivers (its error is checked at midpoints only).
  let actual = 0;
  const { vertices: v, triangles: t } = last;
  for (let i = 0; i < t.length; i += 3) {
    const [ax, ay, bx, by, cx, cy] = [v[2 * t[i]], v[2 * t[i] + 1], v[2 * t[i + 1]], v[2 * t[i + 1] + 1], v[2 * t[i + 2]], v[2 * t[i + 2] + 1]];
    const za = terrain[ay * w + ax], zb = terrain[by * w + bx], zc = terrain[cy * w + cx];
    const area = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax);
    for (let y = Math.min(ay, by, cy); y <= Math.max(ay, by, cy); y++) {
      for (let x = Math.min(ax, bx, cx); x <= Math.max(ax, bx, cx); x++) {
        const w0 = ((bx - x) * (cy - y) - (by - y) * (cx - x)) / area;
        const w1 = ((cx - x) * (ay - y) - (cy - y) * (ax - x)) / area;
        const w2 = 1 - w0 - w1;
        if (w0 < -1e-9 || w1 < -1e-9 || w2 < -1e-9) continue;
        actual = Math.max(actual, Math.abs(terrain[y * w + x] - (w0 * za + w1 * zb + w2 * zc)));
      }
    }
  }
  console.log(JSON.stringify({ maxError, actual, triangles, build_ms: median(build), extract_ms: median(extract) }));
}
JS

errors="0.5 2 8"
node "$tmp/martini.mjs" "$tmp/height.pfm" "$RUNS" $errors > "$tmp/martini.jsonl"

printf '%-9s %-9s | %11s %9s %9s %9s | %10s %9s %9s %9s | %7s %9s\n' \
  "maxError" "epsilon" "martini tri" "build ms" "mesh ms" "total ms" "dmesh tri" "build ms" "mesh ms" "total ms" "speedup" "tri ratio"
for e in $errors; do
  m=$(grep "\"maxError\":$e," "$tmp/martini.jsonl")
  actual=$(M="$m" python3 -c 'import json, os; print(json.loads(os.environ["M"])["actual"])')
  # dmesh at epsilon = maxError, then at the bound martini actually achieved.
  for eps in "$e" "$actual"; do
    for r in $(seq "$RUNS"); do
      target/release/dmesh mesh --depth "$tmp/height.pfm" --camera "$tmp/camera.json" --epsilon "$eps" --segment none --threads 1 --json
    done > "$tmp/dmesh.jsonl"
    M="$m" python3 - "$tmp/dmesh.jsonl" "$e" "$eps" <<'PY'
import json, os, statistics, sys
m = json.loads(os.environ["M"])
runs = [json.loads(l) for l in open(sys.argv[1])]
b = statistics.median(r["build_ms"] for r in runs)
x = statistics.median(r["extract_ms"] for r in runs)
t = runs[0]["triangles"]
mt = m["build_ms"] + m["extract_ms"]
eps = float(sys.argv[3])
print(f'{sys.argv[2]:<9} {eps:<9.3f} | {m["triangles"]:>11} {m["build_ms"]:>9.2f} {m["extract_ms"]:>9.2f} {mt:>9.2f} | {t:>10} {b:>9.2f} {x:>9.2f} {b + x:>9.2f} | {mt / (b + x):>6.2f}x {t / m["triangles"]:>9.3f}')
PY
  done
done
echo "epsilon: dmesh's tolerance, first = martini's maxError, second = the largest deviation of any sample from martini's mesh"
echo "dmesh guarantees |z - mesh| <= epsilon at every sample; martini checks its error at midpoints only"
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), node $(node --version)"
