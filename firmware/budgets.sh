#!/usr/bin/env bash
# Measure the firmware's budgets (issue: firmware under QEMU), reproducibly:
#   flash = .vector_table + .text + .rodata + the .data image (copied to RAM
#   at boot, so it is in flash too), static RAM = .data + .bss + .uninit,
#   peak stack (painted stack, read back by the console report),
#   guest instructions per scan at the defaults (5 passes), at 1 pass, at
#   preset v3.1 (30 passes) and with fast-math,
#   counted exactly by tools/qemu-icount between `scan_begin` and `scan_end`.
# Usage: firmware/budgets.sh   (needs qemu-system-arm, gcc, python3, binutils)
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
cd "$here"
elf=target/thumbv7em-none-eabihf/release/lms-firmware
mkdir -p target
gcc -O2 -shared -fPIC -Wall -o target/icount.so ../tools/qemu-icount/icount.c

section() { size -A "$elf" | awk -v s="$1" '$1 == s { print $2 }'; }

measure() { # label, then cargo build arguments
  local label="$1"; shift
  cargo build -q --release "$@"
  local begin end
  begin=$(nm "$elf" | awk '/ T scan_begin$/ { print "0x" $1 }')
  end=$(nm "$elf" | awk '/ T scan_end$/ { print "0x" $1 }')
  rm -f target/icount.log
  SMOKE_NO_CLOCK_CHECK=1 QEMU_EXTRA="-plugin $here/target/icount.so,begin=$begin,end=$end,skip=1 -d plugin -D $here/target/icount.log" \
    ./qemu-smoke.py > target/budget-smoke.txt 2>&1 || { cat target/budget-smoke.txt; exit 1; }
  local counts stack
  counts=$(grep 'scans=' target/icount.log | sed 's/icount: //')
  stack=$(grep -o 'stack peak reported: [0-9]* of [0-9]* bytes' target/budget-smoke.txt | awk '{print $4}')
  printf '%-22s %s, loop stack peak %s B\n' "$label" "$counts" "$stack"
}

cargo build -q --release
text=$(section .text); rodata=$(section .rodata); vt=$(section .vector_table)
data=$(section .data); bss=$(section .bss); uninit=$(section .uninit)
kib() { awk -v b="$1" 'BEGIN { printf "%.1f", b / 1024 }'; }
flash=$((vt + text + rodata + data)); ram=$((data + bss + ${uninit:-0}))
echo "flash (.vector_table + .text + .rodata + .data image): $flash B ($(kib $flash) KiB; goal <= 96 KiB)"
echo "static RAM (.data + .bss + .uninit): $ram B ($(kib $ram) KiB; goal <= 16 KiB): .data $data, .bss $bss, .uninit ${uninit:-0}"
measure "defaults (5 passes)"
LMS_ITERATIONS=1 measure "1 pass"
LMS_PRESET=v3.1 measure "v3.1 (30 passes)"
measure "defaults, fast-math" --features fast-math
cargo build -q --release
