#!/usr/bin/env bash
# `host-bridge verify --qemu` RUNS times in a row on each shared CARMEN log
# (or the logs given), SCANS scans each; prints one line per run and a table
# per log (runs, scans lost, wall time). Fails if any run fails or loses a
# scan. Needs the release host-bridge and the firmware ELF built:
#   cargo build --release -p host-bridge && (cd firmware && cargo build --release)
# Usage: tools/verify-qemu-repeat.sh RUNS SCANS [LOG.gz ...]
set -u
runs=${1:?RUNS}
scans=${2:?SCANS}
shift 2
here=$(cd "$(dirname "$0")/.." && pwd)
data=${LMS_DATA_DIR:-$here/../shared/data/carmen}
logs=("$@")
[ ${#logs[@]} -eq 0 ] && logs=("$data"/*.log.gz)
bin=$here/target/release/host-bridge
elf=$here/firmware/target/thumbv7em-none-eabihf/release/lms-firmware
for f in "$bin" "$elf"; do
  [ -f "$f" ] || { echo "verify-qemu-repeat: $f not built" >&2; exit 2; }
done
failed=0
summary=()
for log in "${logs[@]}"; do
  name=$(basename "$log" .log.gz)
  ok=0 lost=0 start=$(date +%s)
  for ((k = 1; k <= runs; k++)); do
    out=$("$bin" verify --qemu "$elf" --replay "$log" --scans "$scans" --timeout 120 2>&1)
    rc=$?
    line=$(grep -m1 "scans bit-identical" <<< "$out")
    n=$(sed -n 's/.*bit-identical; \([0-9]*\) lost.*/\1/p' <<< "$line")
    lost=$((lost + ${n:-0}))
    if [ $rc -eq 0 ]; then ok=$((ok + 1)); else
      failed=1
      echo "$name run $k FAILED (rc $rc):"; tail -4 <<< "$out" | sed 's/^/    /'
    fi
    echo "$name run $k: ${line#host-bridge verify: }"
  done
  secs=$(($(date +%s) - start))
  summary+=("| $name | $ok/$runs | $lost | $secs s |")
done
echo
echo "| log | runs passed | scans lost | wall |"
echo "|---|---|---|---|"
printf '%s\n' "${summary[@]}"
exit $failed
