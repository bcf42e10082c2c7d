#!/usr/bin/env bash
# Peak resident memory of `host-bridge extract` on a long log (memory
# independent of the log's length; the bound: under 50 MB for a
# 100,000-frame log). Builds the release binary, writes a 100,000-frame
# log to a temporary folder (the CSAIL log's 406 frames repeated, gzip),
# a 1 GB gzip bomb (one 64 MiB-compressed run of zeros), and measures with
# GNU time (`/usr/bin/time -v`, Debian package `time`):
#
#   bash tools/bench/extract-memory.sh [FRAMES]
#
# Reads ../shared/data (never copied into the repository).
set -euo pipefail
cd "$(dirname "$0")/../.."
frames=${1:-100000}
[ -x /usr/bin/time ] || { echo "needs /usr/bin/time (apt-get install time)" >&2; exit 1; }
src=../shared/data/carmen/csail-corrected.log.gz
CARGO_BUILD_JOBS=${CARGO_BUILD_JOBS:-1} cargo build -q --release -p host-bridge
bin=target/release/host-bridge
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
zcat "$src" | grep '^FLASER' > "$tmp/one.log"
per=$(wc -l < "$tmp/one.log")
reps=$(( (frames + per - 1) / per ))
set +o pipefail  # `head` closes the pipe early
for _ in $(seq "$reps"); do cat "$tmp/one.log"; done | head -n "$frames" | gzip -1 > "$tmp/long.log.gz"
set -o pipefail
head -c 1000000000 /dev/zero | gzip -1 > "$tmp/bomb.gz"
measure() { # label, args...
    local label=$1; shift
    /usr/bin/time -v "$bin" "$@" > /dev/null 2> "$tmp/time.txt" || true
    local rss wall
    rss=$(awk -F': ' '/Maximum resident set size/ {print $2}' "$tmp/time.txt")
    wall=$(awk -F': ' '/Elapsed \(wall clock\)/ {print $2}' "$tmp/time.txt")
    printf '%-44s %8.1f MB  %s\n' "$label" "$(echo "$rss / 1024" | bc -l)" "$wall"
}
echo "host-bridge extract, $frames frames ($(du -h "$tmp/long.log.gz" | cut -f1) gzip): peak RSS, wall time"
measure "extract LOG (all frames)" extract "$tmp/long.log.gz"
measure "extract LOG --frames 0" extract "$tmp/long.log.gz" --frames 0
measure "extract LOG --unit cm --frames 0" extract "$tmp/long.log.gz" --unit cm --frames 0
measure "plot LOG --frame $((frames - 1))" plot "$tmp/long.log.gz" --frame $((frames - 1)) --figure scan -o "$tmp/plot.svg"
measure "extract BOMB (1 GB of zeros, gzip)" extract "$tmp/bomb.gz"
measure "extract --count 100000 (synthetic)" extract --count 100000
