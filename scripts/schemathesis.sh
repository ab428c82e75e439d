#!/usr/bin/env bash
# The API contract against the real server: schemathesis (all phases:
# examples, coverage, fuzzing, stateful; every check) runs proto/openapi.yaml
# against `dmesh serve --demo` on a free loopback port, for MAX_TIME seconds
# (default 120). Installs the pinned schemathesis when it is missing.
# Prints a `test result:` line that scripts/test.sh counts.
set -uo pipefail
cd "$(dirname "$0")/.."
bin=${DMESH_BIN:-target/debug}/dmesh
[ -x "$bin" ] || { echo "scripts/schemathesis.sh: $bin is missing: cargo build --bins first" >&2; exit 1; }
want=$(sed -n 's/^schemathesis==//p' proto/requirements-schemathesis.txt)
if [ "$(schemathesis --version 2>/dev/null | awk '{print $NF}')" != "$want" ]; then
  echo "installing schemathesis $want (pip)"
  python3 -m pip install -q --disable-pip-version-check -r proto/requirements-schemathesis.txt 2>&1 | grep -v "running pip as the 'root' user" \
    || true
  command -v schemathesis >/dev/null 2>&1 || { echo "scripts/schemathesis.sh: could not install schemathesis" >&2; exit 1; }
fi
data=$(mktemp -d)
log=$(mktemp)
"$bin" serve --demo --demo-live-fps 2 --listen 127.0.0.1:0 --data "$data" 2>"$log" &
server=$!
trap 'kill $server 2>/dev/null; wait $server 2>/dev/null; rm -rf "$data" "$log"' EXIT
url=
for _ in $(seq 1 600); do
  url=$(sed -n 's/.*dmesh listening on \(http:[^ ]*\)$/\1/p' "$log")
  [ -n "$url" ] && break
  kill -0 $server 2>/dev/null || { cat "$log" >&2; echo "scripts/schemathesis.sh: dmesh serve exited" >&2; exit 1; }
  sleep 0.2
done
[ -n "$url" ] || { echo "scripts/schemathesis.sh: dmesh serve printed no address" >&2; exit 1; }
out=$(mktemp)
(cd proto && schemathesis run openapi.yaml --url "$url" --max-time "${MAX_TIME:-120}" --seed "${SEED:-1}") 2>&1 | tee "$out"
status=${PIPESTATUS[0]}
cases=$(sed -n 's/^ *\([0-9]*\) generated.*/\1/p' "$out" | tail -1)
rm -f "$out"
if [ "$status" = 0 ]; then
  echo "test result: ok. 1 passed; 0 failed (schemathesis, ${cases:-?} cases, 0 failures)"
else
  echo "test result: FAILED. 0 passed; 1 failed (schemathesis)"
fi
exit "$status"
