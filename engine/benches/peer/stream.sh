#!/usr/bin/env bash
# The compact mesh stream against the formats people use, on the same
# meshes, in the same run: one table of bytes per triangle, with outlines
# refined (protocol 6's meshes: "P6"), then protocol 7 as served (outlines
# cut: "P7") against them.
#
# For each case (the demo novel view at tau = 1 px, five views; Middlebury
# Art at epsilon 1, 5, 10 and 20 mm; Cones at 5 mm; the 513 x 513 height
# field of engine/benches/peer/martini.sh at its tolerances), the example
# `stream_table` extracts the meshes as the server does and codes them as
#   - the compact stream without cuts at 8, 10 and 12 depth planes and all
#     of them, under zstd (level 3), brotli (quality 4) and gzip (level 6):
#     tower-http's levels; and with cuts (protocol 7 as served), zstd;
#   - protocol 5 bincode with the same residual bits, zstd;
#   - the source depth maps losslessly, as 16 bits over each map's range:
#     PNG, zstd -19 of the samples and zlib -9 of them (Verlani's
#     "zipped depth map");
# and this script codes the same triangles and camera-frame positions with
#   - meshoptimizer 1.x (npm `meshoptimizer`): vertex cache and fetch
#     reordering, positions quantised per axis to the grid Draco uses, the
#     vertex and index codecs, then gzip -9;
#   - Draco (npm `draco3d`): edgebreaker, speed 0 (most compression), the
#     position quantisation set to the fewest bits whose error bound is at
#     most protocol 6's largest depth error at the same plane count.
# Peers code positions and indices only; protocol 6's bytes include
# everything a client needs to draw and blend (normals and rho are derived).
#
# Usage: engine/benches/peer/stream.sh [DATA_DIR]     (from the repository root;
#        DATA_DIR defaults to ../shared/data)
set -euo pipefail
cd "$(dirname "$0")/../../.."
data=${1:-../shared/data}
command -v node >/dev/null || { echo "node is required (apt-get install nodejs)" >&2; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

cargo build --release --quiet -p dmesh-client --example stream_table
target/release/examples/stream_table "$data" "$tmp" > "$tmp/rows.jsonl"
(cd "$tmp" && npm install --silent --no-audit --no-fund meshoptimizer@1.3.0 draco3d@1.5.7 >/dev/null)

cat > "$tmp/peers.mjs" <<'JS'
import fs from 'node:fs';
import zlib from 'node:zlib';
import { createRequire } from 'node:module';
import { MeshoptEncoder } from 'meshoptimizer';
const require = createRequire(import.meta.url);
const draco3d = require('draco3d');
const [dir] = process.argv.slice(2);
const rows = fs.readFileSync(`${dir}/rows.jsonl`, 'utf8').trim().split('\n').map((l) => JSON.parse(l));
await MeshoptEncoder.ready;
const draco = await draco3d.createEncoderModule({});
const gzip = (b) => zlib.gzipSync(Buffer.from(b.buffer, b.byteOffset, b.byteLength), { level: 9 }).length;

/** The case's views: positions (f32 xyz) and triangles (u32). */
function views(k) {
  const out = [];
  for (let v = 0; fs.existsSync(`${dir}/case${k}-view${v}.pos`); v++) {
    const p = fs.readFileSync(`${dir}/case${k}-view${v}.pos`);
    const t = fs.readFileSync(`${dir}/case${k}-view${v}.tri`);
    out.push({
      pos: new Float32Array(p.buffer.slice(p.byteOffset, p.byteOffset + p.byteLength)),
      tri: new Uint32Array(t.buffer.slice(t.byteOffset, t.byteOffset + t.byteLength)),
    });
  }
  return out;
}

/** The fewest quantisation bits whose error bound over the box is at most `err`. */
function bitsFor(pos, err) {
  let lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
  for (let i = 0; i < pos.length; i += 3) for (let a = 0; a < 3; a++) { lo[a] = Math.min(lo[a], pos[i + a]); hi[a] = Math.max(hi[a], pos[i + a]); }
  const range = Math.max(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
  let bits = 1;
  while (bits < 30 && range / (2 * (2 ** bits - 1)) > err) bits++;
  return { bits, lo, range };
}

function meshopt(view, q) {
  const tri = view.tri.slice();
  const [remap, unique] = MeshoptEncoder.reorderMesh(tri, true, false);
  const wide = q.bits > 16;
  const stride = wide ? 16 : 8;
  const verts = wide ? new Uint32Array(unique * 4) : new Uint16Array(unique * 4);
  const scale = (2 ** q.bits - 1) / (q.range || 1);
  for (let i = 0; i < remap.length; i++) {
    if (remap[i] === 0xffffffff) continue;
    for (let a = 0; a < 3; a++) verts[4 * remap[i] + a] = Math.round((view.pos[3 * i + a] - q.lo[a]) * scale);
  }
  const vb = MeshoptEncoder.encodeVertexBuffer(new Uint8Array(verts.buffer), unique, stride);
  const ib = MeshoptEncoder.encodeIndexBuffer(new Uint8Array(tri.buffer), tri.length, 4);
  return gzip(vb) + gzip(ib);
}

function dracoSize(view, bits) {
  const enc = new draco.Encoder();
  const builder = new draco.MeshBuilder();
  const mesh = new draco.Mesh();
  builder.AddFacesToMesh(mesh, view.tri.length / 3, view.tri);
  builder.AddFloatAttributeToMesh(mesh, draco.POSITION, view.pos.length / 3, 3, view.pos);
  enc.SetSpeedOptions(0, 0);
  enc.SetAttributeQuantization(draco.POSITION, bits);
  enc.SetEncodingMethod(draco.MESH_EDGEBREAKER_ENCODING);
  const out = new draco.DracoInt8Array();
  const n = enc.EncodeMeshToDracoBuffer(mesh, out);
  draco.destroy(out); draco.destroy(mesh); draco.destroy(builder); draco.destroy(enc);
  return n;
}

const cache = new Map();
for (const r of rows) {
  if (!cache.has(r.case)) cache.set(r.case, views(r.case));
  let mo = 0, dr = 0, qbits = [];
  for (const v of cache.get(r.case)) {
    const q = bitsFor(v.pos, Math.max(r.max_error, 1e-9));
    qbits.push(q.bits);
    mo += meshopt(v, q);
    dr += dracoSize(v, q.bits);
  }
  console.log(JSON.stringify({ ...r, meshopt_gzip: mo, draco: dr, peer_bits: Math.max(...qbits) }));
}
JS
node "$tmp/peers.mjs" "$tmp" > "$tmp/all.jsonl"

python3 - "$tmp/all.jsonl" <<'PY'
import json, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
print(f"machine: {__import__('os').cpu_count()} cores, {open('/proc/cpuinfo').read().split('model name')[1].split(':')[1].splitlines()[0].strip()}")
print()
print("| case | planes | triangles | largest depth error | P6 zstd | P6 br | P6 gzip | P5 bincode zstd | meshopt + gzip | Draco (bits) | P6 vs Draco | depth map PNG16 / zstd / zlib | Verlani ratio | Rust decode ms per 100k |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
for r in rows:
    t = r["triangles"]
    b = lambda k: f"{r[k] / t:.3f}"
    ratio = r["depth_zlib16"] / r["p6_zstd"]
    print(f"| {r['name']} | {r['planes']} | {t:,} | {r['max_error'] * 1000:.3g} mm | {b('p6_zstd')} | {b('p6_br')} | {b('p6_gzip')} | {b('p5_zstd')} | {b('meshopt_gzip')} | {b('draco')} ({r['peer_bits']}) | {r['draco'] / r['p6_zstd']:.2f}x | {r['depth_png16']:,} / {r['depth_zstd16']:,} / {r['depth_zlib16']:,} B | {ratio:.2f} | {r['decode_ms_per_100k']:.1f} |")
print()
print("Bytes per triangle; P6 = protocol 6 as served, P5 = protocol 5. Verlani ratio = the zipped 16-bit depth map over the P6 zstd body.")
print()
print("Protocol 6 at 10 planes, zstd, broken down (each part coded alone, bytes per triangle):")
print()
print("| case | connectivity | depths | reach | header and the rest |")
print("|---|---|---|---|---|")
for r in rows:
    if r["planes"] != "10":
        continue
    t = r["triangles"]
    rest = r["p6_zstd"] - r["connectivity_zstd"] - r["depths_zstd"] - r["reach_zstd"]
    print(f"| {r['name']} | {r['connectivity_zstd'] / t:.3f} | {r['depths_zstd'] / t:.3f} | {r['reach_zstd'] / t:.3f} | {rest / t:.3f} |")
print()
print("Protocol 7 as served (outlines cut) against the same meshes with outlines refined (P6), zstd. Drawn triangles count a cut triangle's parts; decode is the Rust client's, per 100,000 drawn triangles.")
print()
print("| case | planes | P6 triangles | P7 drawn (cuts) | P6 bytes | P7 bytes | P6 / P7 bytes | largest depth error P6 / P7 | decode ms per 100k P6 / P7 |")
print("|---|---|---|---|---|---|---|---|---|")
for r in rows:
    print(f"| {r['name']} | {r['planes']} | {r['triangles']:,} | {r['p7_drawn']:,} ({r['p7_cuts']:,}) | {r['p6_zstd']:,} | {r['p7_zstd']:,} | {r['p6_zstd'] / r['p7_zstd']:.2f} | {r['max_error'] * 1000:.3g} / {r['p7_max_error'] * 1000:.3g} mm | {r['decode_ms_per_100k']:.1f} / {r['p7_decode_ms_per_100k']:.1f} |")
print()
# Issue 59's goals that this table can judge, each by its stated criterion.
art = [r for r in rows if r["name"].startswith("art epsilon 10 mm") and r["planes"] == "10"]
if art:
    a = art[0]
    ratio = a["p6_zstd"] / a["p7_zstd"]
    verdict = "met" if ratio >= 2 else "not met"
    print(f"- **Bytes at least halved** (Art at epsilon 1 cm, 10 planes, zstd; criterion P6 / P7 >= 2): {a['p6_zstd']:,} B refined, {a['p7_zstd']:,} B cut, {ratio:.2f}x: {verdict}.")
slower = [r for r in rows if r["p7_decode_ms_per_100k"] > r["decode_ms_per_100k"]]
verdict = "met" if not slower else "not met"
print(f"- **Decode per triangle no slower** (criterion: P7's ms per 100k drawn triangles at most P6's, every row of this run): slower on {len(slower)} of {len(rows)} rows: {verdict}.")
PY
