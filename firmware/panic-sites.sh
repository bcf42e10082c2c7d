#!/usr/bin/env bash
# List every call to a panic entry point left in a Cortex-M ELF, with the
# chain of (inlined) functions and source lines it sits in.
#
#   firmware/panic-sites.sh ELF [--fail-on lms_core]
#
# Panic entry points: `core::panicking::*`, `core::slice::index::*_fail`,
# `core::option::unwrap_failed`, `core::result::unwrap_failed`,
# `core::cell::panic_already_*` and defmt's `_defmt_panic`. With
# `--fail-on PATTERN` the script exits 1 if any call site has a frame
# matching PATTERN (e.g. `lms_core`: no panic path of the core may survive
# in the firmware). Needs llvm-objdump and llvm-addr2line (Debian: llvm).
set -euo pipefail
elf="$1"; shift
fail_on=""
if [ "${1:-}" = "--fail-on" ]; then fail_on="$2"; fi
objdump=$(command -v llvm-objdump || ls /usr/bin/llvm-objdump-* 2>/dev/null | head -1)
addr2line=$(command -v llvm-addr2line || ls /usr/bin/llvm-addr2line-* 2>/dev/null | head -1)
dis=$(mktemp); trap 'rm -f "$dis"' EXIT
"$objdump" -d --no-show-raw-insn "$elf" > "$dis"
# Panic entry points: address and demangled name.
mapfile -t targets < <(nm -C "$elf" | awk '$2 ~ /^[tTwW]$/' | grep -E \
  ' (core::panicking::|core::slice::index::.*fail|core::option::unwrap_failed|core::result::unwrap_failed|core::option::expect_failed|core::cell::panic_already|_defmt_panic$|core::str::slice_error_fail)' || true)
sites=0; bad=0
for t in "${targets[@]}"; do
  addr=$(printf '%x' $(( 0x${t%% *} & ~1 )))
  name=${t#* * }
  # Direct calls and tail calls to it (bl / b.w / b).
  while read -r site; do
    [ -n "$site" ] || continue
    chain=$("$addr2line" -i -f -C -e "$elf" "0x$site" | paste - - \
      | sed -E 's#/root/.cargo/registry/src/[^/]*/##; s#/rustc/[0-9a-f]+/library/#std:#; s#'"$(cd "$(dirname "$elf")" && git rev-parse --show-toplevel 2>/dev/null || echo /nonexistent)"'/##' \
      | awk -F'\t' '{ sub(/::h[0-9a-f]{16}$/, "", $1); printf "    %s (%s)\n", $1, $2 }')
    # Skip the panic machinery calling itself.
    first=$(printf '%s\n' "$chain" | head -1)
    case "$first" in *core::panicking::*|*core::slice::index::slice_index_fail*|*core::option::unwrap_failed*|*core::result::unwrap_failed*) continue ;; esac
    sites=$((sites + 1))
    echo "call to $name at 0x$site:"
    printf '%s\n' "$chain"
    if [ -n "$fail_on" ] && printf '%s\n' "$chain" | grep -q "$fail_on"; then bad=$((bad + 1)); fi
  done < <(grep -E "^\s*[0-9a-f]+:\s+(bl|b\.w|b)\s+0x$addr\b" "$dis" | awk '{ sub(":", "", $1); print $1 }')
done
echo "$sites panic call site(s)${fail_on:+; $bad with a frame matching '$fail_on'}"
[ "$bad" -eq 0 ]
