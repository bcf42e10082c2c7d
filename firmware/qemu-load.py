#!/usr/bin/env python3
"""Sustained load on the firmware under QEMU: a long stream of scans.

    firmware/qemu-load.py [--scans N] [ELF]      (default 500 scans, the release ELF)

Boots the co-processor firmware with firmware/run-qemu.sh, brings the
sensor up with qemu-smoke.py's fake LMS, asks for the stream on the host
port, then sends N distinct 361-value scans as fast as QEMU takes them
(QEMU moves about 10 KB/s into a USART and leaves the rest in the socket,
so nothing is lost while the firmware keeps up). Checks: every scan comes
back byte for byte, each followed by its feature telegrams D0-D4; the
console's counters say N in, N out, nothing dropped, rejected or lost;
the sensor receive queue's peak stays below its capacity. Prints the
throughput and what 10 000 scans would take. Python 3 standard library.
"""

import importlib.util
import os
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
FIRMWARE = HERE

args = sys.argv[1:]
scans = 500
if "--scans" in args:
    i = args.index("--scans")
    scans = int(args[i + 1])
    del args[i:i + 2]
elf = os.path.abspath(args[0]) if args else os.path.join(
    FIRMWARE, "target/thumbv7em-none-eabihf/release/lms-firmware")

# qemu-smoke.py's fake LMS, client reader and helpers (it reads its ELF
# from sys.argv at import: give it ours).
sys.argv = [sys.argv[0], elf]
spec = importlib.util.spec_from_file_location("smoke", os.path.join(FIRMWARE, "qemu-smoke.py"))
smoke = importlib.util.module_from_spec(spec)
spec.loader.exec_module(smoke)


def main():
    base = int(os.environ.get("QEMU_PORT_BASE") or smoke.free_port_base())
    timeout = int(scans / 5) + 120
    tmp = tempfile.mkdtemp(prefix="lms-qemu-load-")
    env = dict(os.environ, QEMU_TRANSPORT="tcp", QEMU_PORT_BASE=str(base),
               QEMU_TIMEOUT=str(timeout))
    with open(os.path.join(tmp, "log.txt"), "w") as log:
        qemu = subprocess.Popen([os.path.join(FIRMWARE, "run-qemu.sh"), elf], env=env,
                                stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    try:
        deadline = time.monotonic() + 10
        host = smoke.connect(base + 1, deadline)
        sensor = smoke.connect(base + 2, deadline)
        control = smoke.connect(base + 3, deadline)
        first = smoke.wait_for_console(control, deadline)
        smoke.check("console answers", bool(first))

        lms = smoke.FakeSensor(sensor)
        lms.start()
        reader = smoke.HostReader(host)
        reader.start()
        smoke.opt_in(host, reader)
        host.sendall(smoke.telegram(0x00, bytes([0x20, 0x24])))
        smoke.check("sensor bring-up", lms.streaming.wait(15), " ".join(lms.requests))

        want = [smoke.room_scan(k) for k in range(scans)]
        # Distinct scans: the scan number in the first value (mm).
        for k, t in enumerate(want):
            body = bytearray(t[:-2])
            body[7:9] = (1000 + k).to_bytes(2, "little")
            want[k] = bytes(body) + smoke.lms_crc(body).to_bytes(2, "little")
        start = time.monotonic()
        for t in want:
            lms.send(t)

        # Done when all are back, or the host line has been quiet for 5 s
        # (scans dropped whole by the host-line budget, counted: 2c).
        seen = {"n": 0, "at": time.monotonic()}

        def done(ts):
            if len(ts) != seen["n"]:
                seen["n"], seen["at"] = len(ts), time.monotonic()
            n = sum(1 for t in ts if smoke.cmd(t) == 0xD0)
            return n >= scans or (n > 0 and time.monotonic() - seen["at"] > 5)
        ok = reader.wait_for(done, timeout - 30)
        elapsed = time.monotonic() - start
        b0 = [t for t in reader.telegrams if smoke.cmd(t) == 0xB0]
        it = iter(want)
        in_order = all(any(g == w for w in it) for g in b0)
        smoke.check(f"{scans} scans passed through byte for byte (or dropped whole and counted)",
                    b0 and in_order, f"{len(b0)} B0 back, in order: {in_order}")
        seq = [smoke.cmd(t) for t in reader.telegrams if smoke.cmd(t) is not None]
        groups = 0
        i = seq.index(0xB0) if 0xB0 in seq else len(seq)
        while i < len(seq):
            j = i + 1
            while j < len(seq) and seq[j] != 0xB0:
                j += 1
            if sorted(set(seq[i + 1:j])) == [0xD0, 0xD1, 0xD2, 0xD3, 0xD4] or \
               sorted(set(seq[i + 1:j])) == [0xD0, 0xD1, 0xD3, 0xD4]:
                groups += 1
            i = j
        smoke.check("features after every scan", groups == len(b0), f"{groups} feature groups")
        smoke.check("host stream intact", reader.deframer.bad == 0,
                    f"{reader.raw} bytes, {reader.deframer.bad} skipped")

        r, _ = smoke.report(control)
        smoke.check("console counters", int(r["scans_in"]) == scans
                    and int(r["feature_scans_out"]) == len(b0)
                    and int(r["host_scans_dropped"]) == scans - len(b0)
                    and int(r["scans_dropped"]) == 0 and int(r["scans_rejected"]) == 0
                    and int(r["sensor_crc_errors"]) == 0,
                    " ".join(f"{k}={r[k]}" for k in ("scans_in", "feature_scans_out",
                                                      "host_scans_dropped", "scans_dropped",
                                                      "scans_rejected", "sensor_crc_errors")))
        lost = sum(int(r[f"{side}_{k}"]) for side in ("host", "sensor")
                   for k in ("dropped", "overrun", "line_errors"))
        smoke.check("no byte lost", lost == 0,
                    f"sensor queue peak {r['sensor_peak']} B of 8191, host queue peak {r['host_peak']} B, "
                    f"stack peak {r['stack_peak']} B")
        rate = scans / elapsed if elapsed > 0 else 0
        print(f"throughput: {scans} scans in {elapsed:.1f} s wall = {rate:.2f} scans/s "
              f"({rate * 732 / 1000:.1f} KB/s of B0 into the sensor USART); "
              f"10 000 scans would take {10000 / rate / 60:.1f} min at this rate" if rate else "no rate")
        control.sendall(b"q")
        smoke.read_line(control)
        rc = qemu.wait(timeout=10)
        smoke.check("console q exits with 0", rc == 0, f"exit code {rc}")
    finally:
        if qemu.poll() is None:
            os.killpg(qemu.pid, 15)
            qemu.wait(timeout=10)
    failed = smoke.results.count(False)
    print(f"{len(smoke.results) - failed} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
