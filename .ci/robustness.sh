#!/usr/bin/env bash
# Robustness checks: property tests with more
# cases, the faulty-line tables, sustained load (10 000 scans, release), the
# link-time no-panic proof, the panic sites of the real firmware, and a
# bounded fuzzing smoke run. Called by .ci/run; runs on its own too:
#
#   .ci/robustness.sh            # ~6 min on 2 cores (fuzzing 7 × 20 s)
#
# Settings (environment): FUZZ_SECONDS per target (default 20; 0 skips
# fuzzing), PROPTEST_CASES (default 10000), QEMU_LOAD_SCANS (default unset:
# skipped; e.g. 500 streams that many scans through the firmware under QEMU
# with firmware/qemu-load.py, which takes 6-14 scans/s: 1-2 min for 500).
set -euo pipefail
cd "$(dirname "$0")/.."
step() { printf '\n=== %s ===\n' "$*"; }

step "property tests (PROPTEST_CASES=${PROPTEST_CASES:-10000}, release)"
PROPTEST_CASES="${PROPTEST_CASES:-10000}" \
  cargo test -q --release -p lms-core --test props_pipeline --test props_telegram

step "faulty serial line (tables)"
cargo test -q --release -p lms-core --test faulty_line -- --nocapture --test-threads=1

step "sustained load: 10 000 scans at 500 kBd, no allocation in poll (release)"
cargo test -q --release -p lms-core --test sustained_load -- --include-ignored --nocapture

step "no reachable panic in the core as the firmware uses it (link-time proof)"
# Builds only the `panic-proof` binary; the firmware's own ELF is untouched.
(cd firmware && cargo build -q --release --features panic-proof --bin panic-proof)
echo "panic-proof linked: no panic path left in the core's entry points"

step "panic call sites left in the firmware (none may come from the core)"
if ! command -v llvm-objdump > /dev/null || ! command -v llvm-addr2line > /dev/null; then
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends llvm
fi
(cd firmware && cargo build -q --release)
firmware/panic-sites.sh firmware/target/thumbv7em-none-eabihf/release/lms-firmware --fail-on lms_core \
  | grep -v ' (std:' 

if [ "${FUZZ_SECONDS:-20}" != 0 ]; then
  step "fuzzing smoke run (${FUZZ_SECONDS:-20} s per target)"
  fuzz/run.sh "${FUZZ_SECONDS:-20}"
fi

if [ -n "${QEMU_LOAD_SCANS:-}" ]; then
  step "firmware under QEMU: $QEMU_LOAD_SCANS scans"
  firmware/qemu-load.py --scans "$QEMU_LOAD_SCANS"
fi
echo "robustness checks passed"
