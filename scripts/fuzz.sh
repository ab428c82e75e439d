#!/usr/bin/env bash
# The fuzz targets (fuzz/fuzz_targets: every decoder that takes outside
# bytes), each run for SECONDS (default 15) from its committed corpus
# (fuzz/corpus/TARGET), with libFuzzer (libfuzzer-sys) and no sanitizer: the
# workspace forbids unsafe code, so a crash is a panic, which libFuzzer
# reports. The targets are built as `cargo fuzz build --sanitizer none -O`
# builds them (the same coverage instrumentation and `--cfg fuzzing`, for
# the host target only, so build scripts stay uninstrumented), by cargo
# itself: a fresh machine need not compile cargo-fuzz first. `cargo fuzz
# run TARGET` works on these targets too. Prints a `test result:` line that
# scripts/test.sh counts.
#
#   bash scripts/fuzz.sh [SECONDS] [TARGET...]
set -uo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-15}
shift || true
host=$(rustc -vV | sed -n 's/^host: //p')
targets=("$@")
if [ ${#targets[@]} = 0 ]; then
  mapfile -t targets < <(sed -n 's/^name = "\([a-z_]*\)"$/\1/p' fuzz/Cargo.toml | grep -v '^dmesh-fuzz$')
fi
cd fuzz
export RUSTFLAGS="-Cpasses=sancov-module -Cllvm-args=-sanitizer-coverage-level=4 \
-Cllvm-args=-sanitizer-coverage-inline-8bit-counters -Cllvm-args=-sanitizer-coverage-pc-table \
-Cllvm-args=-sanitizer-coverage-trace-compares --cfg fuzzing"
cargo build --release --bins --target "$host" 2>&1 | tail -2
[ "${PIPESTATUS[0]}" = 0 ] || { echo "scripts/fuzz.sh: the fuzz targets do not build" >&2; exit 1; }
bin="target/$host/release"
passed=0
failed=0
for t in "${targets[@]}"; do
  mkdir -p "corpus/$t"
  echo "fuzz $t: ${seconds} s"
  mkdir -p "artifacts/$t"
  if "$bin/$t" "corpus/$t" -artifact_prefix="artifacts/$t/" -max_total_time="$seconds" -rss_limit_mb=2048 -max_len=65536 \
      >"/tmp/fuzz-$t.log" 2>&1; then
    passed=$((passed + 1))
    grep -E "^Done [0-9]+ runs" "/tmp/fuzz-$t.log" | tail -1
  else
    failed=$((failed + 1))
    tail -40 "/tmp/fuzz-$t.log"
    echo "fuzz $t FAILED: the input is in fuzz/artifacts/$t/" >&2
  fi
done
if [ "$failed" = 0 ]; then
  echo "test result: ok. $passed passed; 0 failed (fuzz, ${seconds} s per target)"
else
  echo "test result: FAILED. $passed passed; $failed failed (fuzz)"
  exit 1
fi
