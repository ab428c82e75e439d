#!/usr/bin/env bash
# A loopback cluster, as docker/compose.yaml runs it in containers:
# moto_server (an in-memory S3 API), three `dmesh serve --store` replicas
# over one bucket, and HAProxy in front with docker/haproxy.cfg.
#
#   bash scripts/cluster.sh           start it, upload the demo scene through
#                                     the balancer, print the address, run
#                                     until Ctrl-C
#   bash scripts/cluster.sh --bench   measure what a replica costs on the
#                                     cache-hit render path against a single
#                                     node (same run), over moto and over
#                                     s3s-fs (file-backed), print a table, exit
#
# Needs haproxy (apt-get install -y haproxy), moto_server
# (pip install 'moto[server]') and, for --bench, s3s-fs
# (cargo install s3s-fs --version 0.14.1 --features binary --locked: a
# release build; scripts/test.sh installs a debug one, enough for its tests
# but not for a benchmark);
# builds the release binaries.
set -euo pipefail
cd "$(dirname "$0")/.."
mode=${1:-serve}
case "$mode" in serve | --bench) ;; *)
    echo "usage: bash scripts/cluster.sh [--bench]" >&2
    exit 2
    ;;
esac
tools="haproxy moto_server python3"
[ "$mode" = --bench ] && tools="$tools s3s-fs"
for tool in $tools; do
    command -v "$tool" >/dev/null || {
        echo "$tool is missing (haproxy: apt-get install -y haproxy; moto_server: pip install 'moto[server]';" \
            "s3s-fs: cargo install s3s-fs --version 0.14.1 --features binary --locked)" >&2
        exit 1
    }
done

cargo build --release --workspace --bins -q
bin=$PWD/target/release
tmp=$(mktemp -d)
pids=()
cleanup() {
    for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
    wait 2>/dev/null || true
    rm -rf "$tmp"
}
trap cleanup EXIT INT TERM

port() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'; }
wait_up() { # URL
    for _ in $(seq 600); do
        python3 -c "import urllib.request,sys; urllib.request.urlopen(sys.argv[1], timeout=1)" "$1" 2>/dev/null && return 0
        sleep 0.1
    done
    echo "$1 did not answer in 60 s" >&2
    exit 1
}

serve() { # PORT ARGS...
    local p=$1
    shift
    "$bin/dmesh" serve --listen "127.0.0.1:$p" "$@" >>"$tmp/replica-$p.log" 2>&1 &
    pids+=($!)
    wait_up "http://127.0.0.1:$p/healthz"
}

# cluster NAME: three replicas over the S3 endpoint in AWS_ENDPOINT_URL and
# HAProxy in front; sets $front and $replicas.
cluster() {
    local conf p k
    conf=$(cat docker/haproxy.cfg)
    replicas=()
    for k in 1 2 3; do
        p=$(port)
        replicas+=("$p")
        serve "$p" --store s3://dmesh/cluster
        conf=${conf//dmesh-$k:8080/127.0.0.1:$p}
    done
    front=$(port)
    conf=${conf//bind :8080/bind 127.0.0.1:$front}
    echo "$conf" >"$tmp/haproxy-$1.cfg"
    haproxy -db -f "$tmp/haproxy-$1.cfg" >"$tmp/haproxy-$1.log" 2>&1 &
    pids+=($!)
    wait_up "http://127.0.0.1:$front/healthz"
    # Every replica up in HAProxy's eyes: two health checks 250 ms apart.
    sleep 0.7
    "$bin/dmesh-client" ingest --server "http://127.0.0.1:$front" --scene demo --simulate demo >/dev/null 2>&1
}

s3_port=$(port)
moto_server -H 127.0.0.1 -p "$s3_port" >"$tmp/moto.log" 2>&1 &
pids+=($!)
wait_up "http://127.0.0.1:$s3_port/"
python3 -c "import urllib.request,sys; urllib.request.urlopen(urllib.request.Request(sys.argv[1], method='PUT'))" \
    "http://127.0.0.1:$s3_port/dmesh"
export AWS_ENDPOINT_URL=http://127.0.0.1:$s3_port AWS_ALLOW_HTTP=true AWS_REGION=us-east-1 \
    AWS_ACCESS_KEY_ID=test AWS_SECRET_ACCESS_KEY=test
cluster moto

if [ "$mode" = serve ]; then
    echo "HAProxy on http://127.0.0.1:$front over replicas on ports ${replicas[*]}, moto on $s3_port"
    echo "scene 'demo' uploaded; e.g. open http://127.0.0.1:$front/ or run"
    echo "  $bin/dmesh-client loadtest --server http://127.0.0.1:$front --scene demo --duration 10"
    echo "logs in $tmp; Ctrl-C stops everything"
    wait
    exit 0
fi

# --bench: the same demo scene on a single node (file store), on one
# replica at the defaults (the scene's owner) and checking on every request
# (--revalidate-ms 0), through HAProxy; then one replica and HAProxy over
# s3s-fs. Each target loaded in turn, three rounds.
owner_of() { # FRONT PORT: the replica HAProxy sends scene demo to
    python3 -c "
import urllib.request,sys
r = urllib.request.urlopen(sys.argv[1])
print(r.headers['X-Upstream'].rsplit(':', 1)[1])" "http://127.0.0.1:$1/v1/scenes/demo/views"
}
single=$(port)
serve "$single" --data "$tmp/single"
"$bin/dmesh-client" ingest --server "http://127.0.0.1:$single" --scene demo --simulate demo >/dev/null 2>&1
strict=$(port)
serve "$strict" --store s3://dmesh/cluster --revalidate-ms 0 --replica-id none
targets=("single node, file store=$single" "moto: one replica, defaults=$(owner_of "$front")"
    "moto: one replica, --revalidate-ms 0=$strict" "moto: HAProxy over 3 replicas=$front")

fs_port=$(port)
mkdir -p "$tmp/s3s/dmesh"
s3s-fs --host 127.0.0.1 --port "$fs_port" --access-key test --secret-key test "$tmp/s3s" >"$tmp/s3s.log" 2>&1 &
pids+=($!)
python3 -c "
import socket, sys, time
for _ in range(600):
    try:
        socket.create_connection(('127.0.0.1', int(sys.argv[1])), timeout=1).close()
        sys.exit(0)
    except OSError:
        time.sleep(0.1)
sys.exit('s3s-fs did not listen in 60 s')" "$fs_port"
export AWS_ENDPOINT_URL=http://127.0.0.1:$fs_port
cluster s3s-fs
targets+=("s3s-fs: one replica, defaults=$(owner_of "$front")" "s3s-fs: HAProxy over 3 replicas=$front")
seconds=${BENCH_SECONDS:-8}
clients=${BENCH_CLIENTS:-2}
for round in 1 2 3; do
    for t in "${targets[@]}"; do
        p=${t##*=}
        # Warm the target's cache first: the table is of cache hits.
        "$bin/dmesh-client" loadtest --server "http://127.0.0.1:$p" --scene demo --requests 40 --json >/dev/null 2>&1
        "$bin/dmesh-client" loadtest --server "http://127.0.0.1:$p" --scene demo --concurrency "$clients" \
            --duration "$seconds" --json 2>/dev/null | sed "s|^|${t%%=*}\t|" >>"$tmp/bench.tsv"
    done
done
python3 - "$tmp/bench.tsv" "$clients" "$seconds" <<'EOF'
import json, statistics, sys
rows = {}
for line in open(sys.argv[1]):
    name, report = line.rstrip("\n").split("\t", 1)
    rows.setdefault(name, []).append(json.loads(report))
print(f"cache-hit /render of the demo scene, tau 1 px, {sys.argv[2]} clients, {sys.argv[3]} s x 3 rounds (medians)")
print(f"{'target':40} {'req/s':>8} {'p50 ms':>8} {'p99 ms':>8} {'errors':>7}")
for name, rs in rows.items():
    med = lambda k: statistics.median(r[k] for r in rs)
    print(f"{name:40} {med('throughput_rps'):8.1f} {med('p50_ms'):8.2f} {med('p99_ms'):8.2f} {sum(r['errors'] for r in rs):7d}")
EOF
