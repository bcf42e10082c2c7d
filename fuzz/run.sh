#!/usr/bin/env bash
# Run every cargo-fuzz target for a bounded time, seeded from
# fuzz/target/corpus/.
#
#   fuzz/run.sh [SECONDS_PER_TARGET] [TARGET...]     (default 20 s, all targets)
#
# The seeds are written first into fuzz/target/corpus/<target>/ (made from
# ../shared/data, which is never copied into the repository) by `cargo run
# --example seeds`; new inputs and the logs go to fuzz/target/work/<target>/.
# A crash leaves its input in fuzz/artifacts/<target>/ and fails the script.
# Prints libFuzzer's final line per target (executions, cov, ft) and a table.
# Needs the nightly toolchain and cargo-fuzz (installed here if missing).
set -euo pipefail
cd "$(dirname "$0")"
secs="${1:-20}"; shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(framer parsers b0_frame features emulator pipeline coprocessor carmen capture)
rustup toolchain list | grep -q '^nightly' || rustup toolchain install nightly --profile minimal
command -v cargo-fuzz > /dev/null || cargo install -q --locked cargo-fuzz

# Longest input per target: a few telegrams for the framer, a 401-beam
# frame of f32 ranges for the pipeline, a recorded session for the
# co-processor.
max_len() {
  case "$1" in
    framer|features|carmen|capture) echo 4096 ;;
    pipeline|emulator) echo 2048 ;;
    coprocessor) echo 16384 ;;
    *) echo 1024 ;;
  esac
}

cargo run -q --release --example seeds
cargo +nightly fuzz build
mkdir -p target/work
summary=()
status=0
for t in "${targets[@]}"; do
  mkdir -p "target/work/$t"
  log="target/work/$t.log"
  echo "=== $t: ${secs} s"
  if cargo +nightly fuzz run "$t" "target/work/$t" "target/corpus/$t" -- \
      -max_total_time="$secs" -max_len="$(max_len "$t")" -timeout=10 -rss_limit_mb=2048 \
      -print_final_stats=1 > "$log" 2>&1; then
    result=ok
  else
    result=CRASH; status=1
    grep -E 'panicked|ERROR|SUMMARY|Test unit written' "$log" | head -20
  fi
  last=$(grep -E '^#[0-9]+\s+(DONE|pulse|NEW|REDUCE|INITED)' "$log" | tail -1)
  runs=$(awk '/stat::number_of_executed_units/ { print $2 }' "$log")
  cov=$(sed -n 's/.* cov: \([0-9]*\).*/\1/p' <<< "$last")
  ft=$(sed -n 's/.* ft: \([0-9]*\).*/\1/p' <<< "$last")
  corp=$(sed -n 's/.* corp: \([0-9]*\)\/.*/\1/p' <<< "$last")
  echo "$last"
  summary+=("$(printf '%-12s %-6s %12s %7s %7s %6s' "$t" "$result" "${runs:-?}" "${cov:-?}" "${ft:-?}" "${corp:-?}")")
done
echo
printf '%-12s %-6s %12s %7s %7s %6s\n' target result executions cov ft corpus
printf '%s\n' "${summary[@]}"
exit $status
