#!/usr/bin/env bash
# Boot the firmware in QEMU's `netduinoplus2` (STM32F405) with its three
# serial ports on local sockets, decode its defmt log, and stop it for sure.
#
#   ./run-qemu.sh [ELF]          (also cargo's runner: `cargo run --release`)
#
# ELF defaults to target/thumbv7em-none-eabihf/release/lms-firmware.
#
# Serial ports: QEMU listens, a client may connect at any time and
# reconnect. Default transport: TCP on 127.0.0.1 (QEMU_TRANSPORT=tcp)
#   port QEMU_PORT_BASE+1   USART1  host side  (LMS client / host-bridge)
#   port QEMU_PORT_BASE+2   USART2  sensor side (LMS 2xx or its simulator)
#   port QEMU_PORT_BASE+3   USART3  console: 's' report line, 'q' exit 0
# or Unix sockets (QEMU_TRANSPORT=unix) host.sock, sensor.sock and
# control.sock in QEMU_SOCK_DIR.
#
# Rules for clients (QEMU's character devices, measured with QEMU 7.2):
# - Keep reading every port you are connected to. QEMU writes each guest
#   byte to the socket as it is sent and, when the socket is full, stalls
#   the whole emulator (guest clock included) until it drains. A Unix
#   socket is full after ~280 unread bytes (one kernel buffer per byte);
#   TCP on loopback took 580 KB unread without stalling - hence TCP.
# - Bytes sent to a port before the firmware has switched its receivers on
#   are dropped: wait for the console's answer to 's' (or the log's
#   "ready" line) before sending. Bytes the guest sends while no client is
#   connected are discarded.
# - QEMU moves about 8-10 KB/s into each USART (one byte per round trip of
#   its main loop), less than a 500 kBd LMS stream (27 KB/s): a simulator
#   may send faster, QEMU just delivers more slowly; nothing is lost.
#
# Environment:
#   QEMU_TRANSPORT  tcp (default) or unix
#   QEMU_PORT_BASE  TCP base port (default 47000)
#   QEMU_SOCK_DIR   Unix socket directory (default: target/qemu beside this script)
#   QEMU_TIMEOUT    seconds before QEMU is terminated (default 60; it is
#                   always bounded: QEMU does not stop by itself)
#   QEMU_WAIT=1     QEMU waits for a client on each port before the
#                   firmware starts (server=on,wait=on), in port order
#   QEMU_HOST, QEMU_SENSOR, QEMU_CONTROL
#                   a full -serial spec for one port instead, e.g. `null`,
#                   `pty`, `file:/tmp/out.bin`, `unix:/tmp/h.sock,server=on,wait=off`
#   QEMU_EXTRA      more QEMU arguments, e.g. "-icount shift=0" or a plugin
#   DEFMT_RAW=FILE  write the raw defmt frames to FILE instead of decoding
#
# Exit status: the firmware's semihosting exit code (0 asked to stop,
# 1 panic, 2 hard fault, 3 unexpected interrupt), 124 if QEMU timed out.
set -euo pipefail

here="$(cd "$(dirname "$0")" && pwd)"
elf="${1:-$here/target/thumbv7em-none-eabihf/release/lms-firmware}"
[ -f "$elf" ] || { echo "run-qemu.sh: no ELF at $elf (cargo build --release first)" >&2; exit 2; }
transport="${QEMU_TRANSPORT:-tcp}"
port_base="${QEMU_PORT_BASE:-47000}"
sock_dir="${QEMU_SOCK_DIR:-$here/target/qemu}"
timeout_s="${QEMU_TIMEOUT:-60}"
wait_opt=off
[ "${QEMU_WAIT:-0}" = 1 ] && wait_opt=on
mkdir -p "$sock_dir"

port() { # name offset override -> -serial spec
  if [ -n "$3" ]; then
    echo "$3"
  elif [ "$transport" = unix ]; then
    rm -f "$sock_dir/$1.sock"
    echo "unix:$sock_dir/$1.sock,server=on,wait=$wait_opt"
  elif [ "$transport" = tcp ]; then
    echo "tcp:127.0.0.1:$((port_base + $2)),server=on,wait=$wait_opt,nodelay=on"
  else
    echo "run-qemu.sh: QEMU_TRANSPORT must be tcp or unix, not $transport" >&2
    exit 2
  fi
}
host="$(port host 1 "${QEMU_HOST:-}")"
sensor="$(port sensor 2 "${QEMU_SENSOR:-}")"
control="$(port control 3 "${QEMU_CONTROL:-}")"

decode() {
  if [ -n "${DEFMT_RAW:-}" ]; then
    cat > "$DEFMT_RAW"
  elif command -v defmt-print > /dev/null; then
    defmt-print -e "$elf"
  else
    echo "run-qemu.sh: defmt-print not found (cargo install defmt-print); raw log in $sock_dir/defmt.raw" >&2
    cat > "$sock_dir/defmt.raw"
  fi
}

# Job control: the pipeline gets its own process group, so that it can be
# stopped as a whole if this script is interrupted.
set -m
(
  set -o pipefail
  # shellcheck disable=SC2086 # QEMU_EXTRA is a list of arguments
  timeout --kill-after=5 "$timeout_s" \
    qemu-system-arm -M netduinoplus2 -display none -monitor none \
      -semihosting-config enable=on,target=native \
      -serial "$host" -serial "$sensor" -serial "$control" \
      ${QEMU_EXTRA:-} -kernel "$elf" | decode
) &
job=$!
trap 'kill -TERM -- "-$job" 2> /dev/null || true' INT TERM HUP
trap 'kill -TERM -- "-$job" 2> /dev/null || true' EXIT
set +e
wait "$job"
rc=$?
trap - EXIT
exit "$rc"
