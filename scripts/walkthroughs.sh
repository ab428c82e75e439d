#!/usr/bin/env bash
# The walkthrough comparison: full, keyframe and balanced on the demo orbit
# and the terrain fly-over (examples/paths/), against a release server on a
# loopback port with the simulator's ground truth; tables on stdout, CSV,
# JSON and plots under docs/walkthrough/ (or $1).
#
# The server is dedicated to this one client, so its queue wait is raised
# (--queue-wait-ms 200): the full strategy's five concurrent requests per
# frame are queued instead of shed.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-docs/walkthrough}
port=${PORT:-8093}
cargo build --release -q -p dmesh -p dmesh-client --bins
data=$(mktemp -d)
./target/release/dmesh serve --demo --demo-live-fps 0 --listen "127.0.0.1:$port" --data "$data" --queue-wait-ms 200 >"$data/server.log" 2>&1 &
server=$!
trap 'kill $server 2>/dev/null; rm -rf "$data"' EXIT
for _ in $(seq 100); do
  curl -sf "http://127.0.0.1:$port/v1/scenes/demo/views" >/dev/null && break
  sleep 0.1
done
client=./target/release/dmesh-client
url="http://127.0.0.1:$port"
$client ingest --server "$url" --scene terrain --simulate examples/scenes/terrain.json >/dev/null 2>&1
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)"
# WIRE=bincode measures protocol 5 instead of the compact stream.
wire=(--wire "${WIRE:-compact}")
$client walkthrough --server "$url" --scene demo --path examples/paths/demo-orbit.json --truth demo --out "$out" "${wire[@]}"
echo
$client walkthrough --server "$url" --scene terrain --path examples/paths/terrain-flyover.json \
  --truth examples/scenes/terrain.json --out "$out" "${wire[@]}"
