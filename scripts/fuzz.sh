#!/usr/bin/env bash
# The fuzz targets (fuzz/fuzz_targets: every decoder that takes outside
# bytes), each run for SECONDS (default 15) from its committed corpus
# (fuzz/corpus/TARGET), with libFuzzer on the stable toolchain
# (RUSTC_BOOTSTRAP=1, no sanitizer: the workspace forbids unsafe code, so a
# crash is a panic, which libFuzzer reports). Installs cargo-fuzz when it is
# missing. Prints a `test result:` line that scripts/test.sh counts.
#
#   bash scripts/fuzz.sh [SECONDS] [TARGET...]
set -uo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-15}
shift || true
export RUSTC_BOOTSTRAP=1
if ! cargo fuzz --version >/dev/null 2>&1; then
  echo "installing cargo-fuzz (cargo install)"
  cargo install cargo-fuzz --version 0.13.2 --locked >/dev/null 2>&1 || { echo "scripts/fuzz.sh: could not install cargo-fuzz" >&2; exit 1; }
fi
targets=("$@")
if [ ${#targets[@]} = 0 ]; then
  mapfile -t targets < <(sed -n 's/^name = "\([a-z_]*\)"$/\1/p' fuzz/Cargo.toml | grep -v '^dmesh-fuzz$')
fi
cd fuzz
cargo fuzz build --sanitizer none -O 2>&1 | tail -2 || exit 1
passed=0
failed=0
for t in "${targets[@]}"; do
  mkdir -p "corpus/$t"
  echo "fuzz $t: ${seconds} s"
  if cargo fuzz run --sanitizer none -O "$t" "corpus/$t" -- -max_total_time="$seconds" -rss_limit_mb=2048 -max_len=65536 \
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
