#!/usr/bin/env bash
# Guest instructions of the pipeline alone (`Extractor::run`, never inlined),
# per scan, counted exactly by tools/qemu-icount from the function's entry to
# its return address in the caller, while `host-bridge verify --qemu` streams
# scans through the firmware and checks them bit for bit.
#
# Why not firmware/budgets.sh's `scan_begin`/`scan_end` markers here: they
# bracket one poll, and under QEMU a poll at 30 passes often processes many
# scans (the sensor bytes keep arriving while the slow host UART is written,
# so the read loop never runs dry); such an interval holds several scans, and
# a smoke run whose first poll never ends shows scans=0. Entry/return of the
# pipeline counts every scan on its own.
#
# Usage (after `cd firmware && cargo build --release` and
# `cargo build --release -p host-bridge`):
#   tools/qemu-icount/pipeline.sh [verify arguments]
# e.g. the noisy-scan budget of README:
#   tools/qemu-icount/pipeline.sh --scene random --seed 7 --count 50 --noise-sigma 0.01 --scans 50
# ICOUNT_MODEL=m4 adds the Cortex-M4F cycle estimate (cycles.h; the figures
# and the model's assumptions are in docs/DESIGN.md, Firmware).
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
cd "$root"
elf=firmware/target/thumbv7em-none-eabihf/release/lms-firmware
so=firmware/target/icount.so
gcc -O2 -shared -fPIC -Wall -o "$so" tools/qemu-icount/icount.c
dis=$(mktemp); log=$(mktemp)
trap 'rm -f "$dis" "$log"' EXIT
llvm-objdump -d --no-show-raw-insn "$elf" > "$dis"
begin=$(awk '/^[0-9a-f]+ <.*Extractor.*3run.*>:$/ { print $1; exit }' "$dis")
[ -n "$begin" ] && begin=$(printf '0x%x' $((0x$begin)))
[ -n "$begin" ] || { echo "no Extractor::run symbol in $elf" >&2; exit 1; }
# Every call site's return address ends an interval (the optimiser may
# duplicate the caller's call; a `bl` is 4 bytes).
sites=$(grep "bl[[:space:]]*${begin}" "$dis" | awk '{ sub(":", "", $1); print $1 }')
[ -n "$sites" ] || { echo "no call of Extractor::run in $elf" >&2; exit 1; }
ends=""
for site in $sites; do ends="$ends,end=$(printf '0x%x' $((0x$site + 4)))"; done
# The exception handlers (the vector table's entries the firmware defines):
# the cycle model charges an exception at each entry.
handlers=""
syms=$(llvm-nm "$elf")
for h in SysTick USART1 USART2 USART3 HardFault DefaultHandler; do
  a=$(awk -v n="$h" '$3 == n && !seen { print $1; seen = 1 }' <<< "$syms")
  [ -z "$a" ] || handlers="$handlers,handler=$(printf '0x%x' $((0x$a & ~1)))"
done
QEMU_EXTRA="-plugin $root/$so,begin=$begin$ends${ICOUNT_PROFILE:+,profile=${ICOUNT_PROFILE_KIND:-1}}${ICOUNT_MODEL:+,model=$ICOUNT_MODEL$handlers} -d plugin -D $log" \
  target/release/host-bridge verify --qemu "$elf" "$@" >&2
[ -z "${ICOUNT_INTERVALS:-}" ] || grep "icount: interval" "$log" > "$ICOUNT_INTERVALS"
grep '^icount: scans=' "$log" | sed 's/icount: //'
# ICOUNT_MODEL=m4: the cycle estimate (tools/qemu-icount/cycles.h).
[ -z "${ICOUNT_MODEL:-}" ] || grep -E '^icount: (cycles|window|model) ' "$log" | sed 's/icount: //'
[ -z "${ICOUNT_PROFILE:-}" ] || grep "icount: block" "$log" > "$ICOUNT_PROFILE"
