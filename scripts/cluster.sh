#!/usr/bin/env bash
# A loopback cluster, as docker/compose.yaml runs it in containers:
# moto_server (an in-memory S3 API), three `dmesh serve --store` replicas
# over one bucket, and nginx in front with docker/nginx.conf.
#
#   bash scripts/cluster.sh           start it, upload the demo scene through
#                                     nginx, print the address, run until Ctrl-C
#   bash scripts/cluster.sh --bench   measure what a replica costs on the
#                                     cache-hit render path against a single
#                                     node (same run), print a table, exit
#
# Needs nginx (apt-get install -y nginx) and moto_server
# (pip install 'moto[server]'); builds the release binaries.
set -euo pipefail
cd "$(dirname "$0")/.."
mode=${1:-serve}
case "$mode" in serve | --bench) ;; *)
    echo "usage: bash scripts/cluster.sh [--bench]" >&2
    exit 2
    ;;
esac
for tool in nginx moto_server python3; do
    command -v "$tool" >/dev/null || {
        echo "$tool is missing (nginx: apt-get install -y nginx; moto_server: pip install 'moto[server]')" >&2
        exit 1
    }
done

cargo build --release --workspace --bins -q
bin=$PWD/target/release
tmp=$(mktemp -d)
# nginx's workers (another user when it runs as root) buffer large uploads here.
chmod 755 "$tmp"
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

s3_port=$(port)
moto_server -H 127.0.0.1 -p "$s3_port" >"$tmp/moto.log" 2>&1 &
pids+=($!)
wait_up "http://127.0.0.1:$s3_port/"
python3 -c "import urllib.request,sys; urllib.request.urlopen(urllib.request.Request(sys.argv[1], method='PUT'))" \
    "http://127.0.0.1:$s3_port/dmesh"
export AWS_ENDPOINT_URL=http://127.0.0.1:$s3_port AWS_ALLOW_HTTP=true AWS_REGION=us-east-1 \
    AWS_ACCESS_KEY_ID=test AWS_SECRET_ACCESS_KEY=test

serve() { # PORT ARGS...
    local p=$1
    shift
    "$bin/dmesh" serve --listen "127.0.0.1:$p" "$@" >>"$tmp/replica-$p.log" 2>&1 &
    pids+=($!)
    wait_up "http://127.0.0.1:$p/healthz"
}

conf=$(cat docker/nginx.conf)
replicas=()
for k in 1 2 3; do
    p=$(port)
    replicas+=("$p")
    serve "$p" --store s3://dmesh/cluster
    conf=${conf//dmesh-$k:8080/127.0.0.1:$p}
done
front=$(port)
conf=${conf//listen 8080;/listen 127.0.0.1:$front;}
conf=${conf/http \{/http \{ access_log off; client_body_temp_path $tmp/body; proxy_temp_path $tmp/proxy;}
echo "$conf" >"$tmp/nginx.conf"
nginx -p "$tmp" -c "$tmp/nginx.conf" -g "daemon off; pid $tmp/nginx.pid; error_log $tmp/nginx-error.log;" &
pids+=($!)
wait_up "http://127.0.0.1:$front/healthz"
"$bin/dmesh-client" ingest --server "http://127.0.0.1:$front" --scene demo --simulate demo >/dev/null 2>&1

if [ "$mode" = serve ]; then
    echo "nginx on http://127.0.0.1:$front over replicas on ports ${replicas[*]}, moto on $s3_port"
    echo "scene 'demo' uploaded; e.g. open http://127.0.0.1:$front/ or run"
    echo "  $bin/dmesh-client loadtest --server http://127.0.0.1:$front --scene demo --duration 10"
    echo "logs in $tmp; Ctrl-C stops everything"
    wait
    exit 0
fi

# --bench: the same demo scene on a single node (file store), on one replica
# over the object store (revalidating every request, and at most every
# second), and through nginx; each target loaded in turn, three rounds.
single=$(port)
serve "$single" --data "$tmp/single"
"$bin/dmesh-client" ingest --server "http://127.0.0.1:$single" --scene demo --simulate demo >/dev/null 2>&1
lazy=$(port)
serve "$lazy" --store s3://dmesh/cluster --revalidate-ms 1000
owner=$(python3 -c "
import urllib.request,sys
r = urllib.request.urlopen(sys.argv[1])
print(r.headers['X-Upstream'].rsplit(':', 1)[1])" "http://127.0.0.1:$front/v1/scenes/demo/views")
targets=("single node, file store=$single" "one replica, --revalidate-ms 0=$owner"
    "one replica, --revalidate-ms 1000=$lazy" "nginx over 3 replicas=$front")
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
print(f"{'target':36} {'req/s':>8} {'p50 ms':>8} {'p99 ms':>8} {'errors':>7}")
for name, rs in rows.items():
    med = lambda k: statistics.median(r[k] for r in rs)
    print(f"{name:36} {med('throughput_rps'):8.1f} {med('p50_ms'):8.2f} {med('p99_ms'):8.2f} {sum(r['errors'] for r in rs):7d}")
EOF
