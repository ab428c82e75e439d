#!/usr/bin/env bash
# Every test of the project, on a fresh machine: the Rust workspace
# (`cargo test --workspace`), then the browser viewer's checks: its type
# check (tsc --checkJs) and its tests in Debian's Chromium against a real
# `dmesh serve`, the API contract (schemathesis over proto/openapi.yaml
# against the real server) and the fuzz targets for a few seconds each.
# Installs Chromium and haproxy (apt), the npm packages (package-lock), schemathesis
# and moto_server (pip), s3s-fs (cargo) when they are missing. Ends with one line:
# `tests: N passed, M failed`.
set -uo pipefail
cd "$(dirname "$0")/.."

die() { echo "scripts/test.sh: $*" >&2; exit 1; }
began=$SECONDS
command -v cargo >/dev/null 2>&1 || die "cargo is not installed: this project needs the Rust toolchain (rustup)"

as_root() { if [ "$(id -u)" = 0 ]; then "$@"; elif command -v sudo >/dev/null 2>&1; then sudo "$@"; else die "need root to run: $*"; fi; }
if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
  echo "installing Node.js and npm (apt)"
  as_root apt-get update -qq && as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq nodejs npm >/dev/null \
    || die "could not install Node.js and npm"
fi
CHROMIUM=${CHROMIUM:-/usr/bin/chromium}
if [ ! -x "$CHROMIUM" ]; then
  echo "installing Chromium (apt)"
  as_root apt-get update -qq && as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null \
    || die "could not install Chromium: the browser tests need it"
  [ -x "$CHROMIUM" ] || die "$CHROMIUM is still missing after apt-get install chromium"
fi
export CHROMIUM
if ! command -v haproxy >/dev/null 2>&1; then
  echo "installing haproxy (apt)"
  as_root apt-get update -qq && as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq haproxy >/dev/null \
    || die "could not install haproxy: the cluster test needs it"
fi
# Real S3 API servers for the object-store tests: moto (in memory) and
# s3s-fs (file-backed, for restarts).
if ! moto_server --help >/dev/null 2>&1; then
  echo "installing moto_server (pip install 'moto[server]')"
  pip install -q 'moto[server]' || die "could not install moto[server]: the object-store tests need it"
fi
if ! command -v s3s-fs >/dev/null 2>&1; then
  # A debug build: it serves loopback tests, and compiles in a fraction of
  # a release build's time on a fresh machine.
  echo "installing s3s-fs (cargo install --debug s3s-fs 0.14.1)"
  cargo install -q --debug s3s-fs --version 0.14.1 --features binary --locked || die "could not install s3s-fs"
fi
web=clients/web
if [ ! -d "$web/node_modules" ] || ! cmp -s "$web/package-lock.json" "$web/node_modules/.package-lock.json"; then
  echo "installing the viewer's npm packages (npm ci)"
  (cd "$web" && npm ci --no-audit --no-fund --loglevel=error) || die "npm ci failed in $web"
fi

echo "installs: $((SECONDS - began)) s"
log=$(mktemp)
trap 'rm -f "$log"' EXIT
status=0
# Runs one phase, teeing its output into the summary's log. A phase that
# fails without a failing test of its own (a test target that does not
# compile, a server that does not start) counts as one failure, so the
# summary never says "0 failed" after a failed phase.
phase() {
  local name=$1 out rc start=$SECONDS
  shift
  out=$(mktemp)
  "$@" 2>&1 | tee "$out"
  rc=${PIPESTATUS[0]}
  cat "$out" >>"$log"
  if [ "$rc" != 0 ]; then
    status=1
    if ! awk '/^test result:/ { for (i = 1; i < NF; i++) if ($(i+1) ~ /^failed/ && $i > 0) f = 1 }
              /^# fail [1-9]/ { f = 1 } END { exit !f }' "$out"; then
      echo "test result: FAILED. 0 passed; 1 failed ($name exited with $rc and no failing test named)" | tee -a "$log"
    fi
  fi
  rm -f "$out"
  echo "phase $name: $((SECONDS - start)) s"
}
tsc_check() { (cd "$web" && npx --no-install tsc -p jsconfig.json) && echo "test result: ok. 1 passed; 0 failed (tsc)"; }
browser_tests() { (cd "$web" && DMESH_BIN="$PWD/../../target/debug" node --test --test-concurrency=1 test/*.test.js); }
cargo --version
# --no-fail-fast: a failing test binary does not hide the ones after it.
phase "cargo test" cargo test --workspace --no-fail-fast
# The browser tests run the binaries the tests above built (debug profile).
phase "cargo build" cargo build --workspace --bins
echo "type check: tsc --checkJs ($web)"
phase "tsc" tsc_check
phase "browser tests" browser_tests
# The API contract: schemathesis against the real server.
phase "schemathesis" bash scripts/schemathesis.sh
# Every decoder of outside bytes, fuzzed for a short bounded time each.
phase "fuzz" bash scripts/fuzz.sh "${FUZZ_SECONDS:-10}"
echo "scripts/test.sh: $((SECONDS - began)) s in all"
# cargo prints a "test result" line per binary, node "# pass N" and "# fail N".
awk '/^test result:/ { for (i = 1; i < NF; i++) { if ($(i+1) ~ /^passed/) p += $i; if ($(i+1) ~ /^failed/) f += $i } }
     /^# pass / { p += $3 } /^# fail / { f += $3 }
     END { printf "tests: %d passed, %d failed\n", p, f; if (p == 0) exit 1 }' "$log" || status=1
exit $status
