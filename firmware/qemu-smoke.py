#!/usr/bin/env python3
"""Boots the firmware under QEMU with run-qemu.sh, drives its three serial
ports and checks what comes out. Python 3 standard library only.

    cd firmware
    cargo build --release && ./qemu-smoke.py [ELF]
    cargo build --release --features standin && ./qemu-smoke.py --standin [ELF]

Default (the co-processor): a fake LMS 2xx on the sensor port answers the
bring-up (20 25, 3B, 20 00, 74, 77, 20 4x, 20 24) and then streams B0 scans
of a room; a client on the host port asks for continuous output (20 24) and
must get every scan byte for byte, each followed by its feature telegrams
(D0-D4, checked CRCs); the counters request 55 is answered (D5); the
console's counters agree.

--standin (the forwarder built with the `standin` feature): host <-> sensor
transparency for all 256 byte values and a 64 KiB burst; sensor telegrams
counted as scans.

Both: the scan markers are in the ELF; the console answers; the SysTick time
base against QEMU's own clock (semihosting SYS_ELAPSED); stack peak; the
scans' cycles (no cycle counter under QEMU: reported as 0); no byte
lost; console `q` ends QEMU with exit code 0; the decoded log has the ready
line. Ports: TCP on 127.0.0.1 at a base it finds free (or QEMU_PORT_BASE);
QEMU starts the firmware once all three are connected (QEMU_WAIT=1), so the
host port's stream is whole from the power-on telegram on.
Ends with "N passed, N failed"; exit status 1 on failure.
"""

import math
import os
import random
import shutil
import socket
import subprocess
import sys
import tempfile
import threading
import time

HERE = os.path.dirname(os.path.abspath(__file__))
STANDIN = "--standin" in sys.argv[1:]
ARGS = [a for a in sys.argv[1:] if a != "--standin"]
ELF = ARGS[0] if ARGS else os.path.join(HERE, "target/thumbv7em-none-eabihf/release/lms-firmware")

STX, ACK = 0x02, 0x06
results = []


def check(name, ok, detail=""):
    results.append(bool(ok))
    print(("ok   " if ok else "FAIL ") + name + (": " + detail if detail else ""), flush=True)


# ---- LMS framing (PROTOCOL.md section 1) ----

def lms_crc(data):
    crc, prev = 0, 0
    for b in data:
        crc = (((crc & 0x7FFF) << 1) ^ 0x8005) if crc & 0x8000 else (crc << 1) & 0xFFFF
        crc ^= b | (prev << 8)
        prev = b
    return crc & 0xFFFF


def telegram(addr, payload):
    """STX, addr, LEN, payload (CMD, data[, status]), CRC."""
    body = bytes([STX, addr]) + len(payload).to_bytes(2, "little") + payload
    return body + lms_crc(body).to_bytes(2, "little")


class Deframer:
    """Telegrams (and ACK bytes) out of a byte stream, CRC checked."""

    def __init__(self):
        self.buf = bytearray()
        self.bad = 0
        self.fed = 0  # bytes taken off the front so far
        self.first_bad = None  # (stream offset, the 48 bytes there) of the first skip

    def skip(self):
        if self.first_bad is None:
            self.first_bad = (self.fed, bytes(self.buf[:48]).hex(" "))
        self.bad += 1
        self.fed += 1
        del self.buf[0]

    def feed(self, data):
        self.buf += data
        out = []
        while self.buf:
            if self.buf[0] == ACK:
                out.append(b"\x06")
                self.fed += 1
                del self.buf[0]
                continue
            if self.buf[0] != STX:
                self.skip()
                continue
            if len(self.buf) < 4:
                break
            total = 4 + int.from_bytes(self.buf[2:4], "little") + 2
            if len(self.buf) < total:
                break
            t = bytes(self.buf[:total])
            if lms_crc(t[:-2]) == int.from_bytes(t[-2:], "little"):
                out.append(t)
                self.fed += total
                del self.buf[:total]
            else:
                self.skip()
        return out


def cmd(t):
    """The command byte of a telegram, None for an ACK."""
    return t[4] if len(t) > 4 else None


def room_scan(k):
    """361 values (180 deg / 0.5 deg, mm): a wall 3 m ahead, side walls 2 m
    away, a box in front; index i at i*0.5 deg, 90 deg straight ahead."""
    rng = random.Random(k)
    words = []
    for i in range(361):
        phi = math.radians(i * 0.5 - 90.0)
        c, s = math.cos(phi), math.sin(phi)
        d = math.inf
        if c > 1e-6:
            d = min(d, 3.0 / c)
        if abs(s) > 1e-6:
            d = min(d, 2.0 / abs(s))
        if -0.2 < phi < 0.1:
            d = min(d, 1.5 / c)
        words.append(min(8182, round((d + rng.uniform(-0.005, 0.005)) * 1000)))
    data = (0x4000 | 361).to_bytes(2, "little") + b"".join(w.to_bytes(2, "little") for w in words)
    return telegram(0x80, bytes([0xB0]) + data + bytes([0x10]))


class FakeSensor(threading.Thread):
    """A minimal LMS 2xx: ACK and a reply for each request; after 20 24 it
    is 'streaming' and the test sends scans through `send`."""

    def __init__(self, sock):
        super().__init__(daemon=True)
        self.sock = sock
        self.lock = threading.Lock()
        self.requests = []
        self.streaming = threading.Event()
        self.config = bytearray(34)

    def send(self, data):
        with self.lock:
            self.sock.sendall(data)

    def reply(self, payload):
        self.send(b"\x06" + telegram(0x80, payload + bytes([0x10])))

    def run(self):
        deframer = Deframer()
        self.sock.settimeout(None)
        while True:
            try:
                data = self.sock.recv(4096)
            except OSError:
                return
            if not data:
                return
            for t in deframer.feed(data):
                if len(t) < 7:
                    continue
                req = t[4:-2]
                self.requests.append(req.hex())
                cmd = req[0]
                if cmd == 0x20:
                    self.reply(bytes([0xA0, 0x00]))
                    if req[1:2] == b"\x24":
                        self.streaming.set()
                    elif req[1:2] == b"\x25":
                        self.streaming.clear()
                elif cmd == 0x3B:
                    self.reply(bytes([0xBB, 0x01]) + req[1:5])
                elif cmd == 0x74:
                    self.reply(bytes([0xF4]) + self.config)
                elif cmd == 0x77:
                    self.config[:] = req[1:35]
                    self.reply(bytes([0xF7, 0x01]) + self.config)
                else:
                    self.reply(bytes([0x92]))


# ---- sockets ----

def free_port_base():
    """A base whose next three TCP ports on 127.0.0.1 are free right now."""
    rng = random.Random()
    for _ in range(50):
        base = rng.randrange(20000, 60000)
        try:
            for offset in (1, 2, 3):
                with socket.socket() as s:
                    s.bind(("127.0.0.1", base + offset))
            return base
        except OSError:
            continue
    raise RuntimeError("no free ports")


def connect(port, deadline):
    while True:
        try:
            return socket.create_connection(("127.0.0.1", port))
        except OSError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.02)


def read_exact(sock, n, timeout=5.0):
    sock.settimeout(timeout)
    buf = bytearray()
    while len(buf) < n:
        chunk = sock.recv(n - len(buf))
        if not chunk:
            break
        buf += chunk
    return bytes(buf)


def wait_for_console(control, deadline):
    """Ask the console for its report until it answers (the receivers are
    all on by then) or `deadline` (time.monotonic()) passes; returns the
    first line or None. Every answer must be read (an unread port stalls
    QEMU), so the answers to the retries are waited out and dropped."""
    first = None
    while first is None and time.monotonic() < deadline:
        control.sendall(b"s")
        try:
            first = read_line(control, timeout=0.2)
        except socket.timeout:
            pass
    time.sleep(0.3)
    control.settimeout(0.1)
    try:
        while control.recv(65536):
            pass
    except socket.timeout:
        pass
    return first


def read_line(sock, timeout=2.0):
    sock.settimeout(timeout)
    buf = bytearray()
    while not buf.endswith(b"\n"):
        chunk = sock.recv(1)
        if not chunk:
            break
        buf += chunk
    return buf.decode()


def report(control):
    control.sendall(b"s")
    line = read_line(control)
    return dict(kv.split("=", 1) for kv in line.split()), time.monotonic()


class HostReader(threading.Thread):
    """Keeps reading the host port (an unread port stalls QEMU) into telegrams."""

    def __init__(self, sock):
        super().__init__(daemon=True)
        self.sock = sock
        self.deframer = Deframer()
        self.telegrams = []
        self.raw = 0

    def run(self):
        self.sock.settimeout(None)
        while True:
            try:
                data = self.sock.recv(65536)
            except OSError:
                return
            if not data:
                return
            self.raw += len(data)
            self.telegrams += self.deframer.feed(data)

    def wait_for(self, pred, timeout):
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if pred(self.telegrams):
                return True
            time.sleep(0.02)
        return pred(self.telegrams)


# ---- the two modes ----

def plumbing(host, sensor, control):
    every = bytes(range(256))
    host.sendall(every)
    check("host -> sensor, 256 byte values", read_exact(sensor, 256) == every)
    sensor.sendall(every)
    check("sensor -> host, 256 byte values", read_exact(host, 256) == every)

    burst = random.Random(1).randbytes(65536)
    sensor.sendall(burst)
    got = read_exact(host, len(burst), timeout=20)
    check("sensor -> host, 64 KiB burst", got == burst, f"{len(got)} bytes back")

    before, _ = report(control)
    scan = room_scan(0)
    reply = telegram(0x80, bytes([0xA0, 0x00, 0x10]))
    sensor.sendall(scan * 3 + b"\x06" + reply)
    got = read_exact(host, 3 * len(scan) + 1 + len(reply))
    check("scan telegrams forwarded", got == scan * 3 + b"\x06" + reply, f"{len(scan)}-byte B0")
    after, _ = report(control)
    n = int(after["scans"]) - int(before["scans"])
    check("scans counted", n == 4, f"{n} telegrams (3 B0 + 1 A0)")


def opt_in(host, reader):
    """The host line to 500 kBd (20 48 -> A0 00), then the feature telegrams
    on (56 01 -> D6 01; docs/PROTOCOL.md): by default the co-processor sends
    only what an LMS would, and at 9600 Bd only every ~30th scan fits."""
    host.sendall(telegram(0x00, bytes([0x20, 0x48])))
    ok = reader.wait_for(lambda ts: any(cmd(t) == 0xA0 for t in ts), 10)
    check("host face answers 20 48", ok, "ACK + A0")
    host.sendall(telegram(0x00, bytes([0x56, 0x01])))
    ok = reader.wait_for(lambda ts: any(cmd(t) == 0xD6 and t[5] == 1 for t in ts), 10)
    check("features switched on (56 01)", ok, "ACK + D6 01")


def coprocessor(host, sensor, control, n_scans=5):
    lms = FakeSensor(sensor)
    lms.start()
    reader = HostReader(host)
    reader.start()

    # The client: 500 kBd, features on, then continuous output, as an LMS
    # client would ask the sensor.
    opt_in(host, reader)
    host.sendall(telegram(0x00, bytes([0x20, 0x24])))
    ok = reader.wait_for(lambda ts: sum(1 for t in ts if cmd(t) == 0xA0) >= 2, 10)
    check("host face answers 20 24", ok, "ACK + A0")

    up = lms.streaming.wait(15)
    check("sensor bring-up", up, " ".join(lms.requests))
    if not up:
        return

    scans = [room_scan(k) for k in range(n_scans)]
    for s in scans:
        lms.send(s)
        time.sleep(0.25)  # spaced: the host-line budget drops scans that arrive bunched (docs/PROTOCOL.md §2c)
    b0 = lambda ts: [t for t in ts if cmd(t) == 0xB0]
    def all_in(ts):
        cmds = [cmd(t) for t in ts]
        starts = [i for i, c in enumerate(cmds) if c == 0xB0]
        return len(starts) >= n_scans and len(cmds) - starts[-1] > 5
    # A scan that arrives while the host line (500 kBd, modelled on the
    # firmware's clock) is still busy by more than a scan period is dropped
    # whole and counted (host_scans_dropped, docs/PROTOCOL.md 2c): under a
    # loaded QEMU the scans can reach the firmware bunched.
    reader.wait_for(all_in, 8)
    got = b0(reader.telegrams)
    it = iter(scans)
    in_order = all(any(g == s for s in it) for g in got)
    check("every scan passed through byte for byte (or dropped whole and counted)",
          got and in_order, f"{len(got)} of {n_scans} B0")

    # After each B0: its feature telegrams D0..D4, in order.
    seq = [cmd(t) for t in reader.telegrams if cmd(t) is not None]
    first = seq.index(0xB0) if 0xB0 in seq else len(seq)
    per_scan = []
    i = first
    while i < len(seq):
        if seq[i] == 0xB0:
            j = i + 1
            while j < len(seq) and seq[j] != 0xB0:
                j += 1
            per_scan.append(seq[i + 1:j])
            i = j
        else:
            i += 1
    want = [0xD0, 0xD1, 0xD2, 0xD3, 0xD4]
    check("features after every scan", len(per_scan) == len(got) and all(sorted(p[:5]) == want for p in per_scan),
          " ".join("+".join(f"{c:02X}" for c in p) for p in per_scan[:2]) + " ...")
    lines = [t for t in reader.telegrams if cmd(t) == 0xD1]
    check("lines found in the room", lines and len(lines[-1]) > 20, f"D1 of {len(lines[-1]) if lines else 0} bytes")
    first = next((t for t in reader.telegrams if len(t) > 5), b"")
    check("the power-on telegram first, whole", first[4:5] == b"\x90", first[5:26].decode(errors="replace"))
    check("host stream intact", reader.deframer.bad == 0, f"{reader.raw} bytes, {reader.deframer.bad} skipped"
          + (f"; the first at byte {reader.deframer.first_bad[0]}: {reader.deframer.first_bad[1]}"
             if reader.deframer.first_bad else ""))

    host.sendall(telegram(0x00, bytes([0x55])))
    ok = reader.wait_for(lambda ts: any(cmd(t) == 0xD5 for t in ts), 10)
    check("counters request 55 answered", ok, "D5")

    r, _ = report(control)
    check("console counters", int(r["scans_in"]) == n_scans and int(r["feature_scans_out"]) == len(got)
          and int(r["host_scans_dropped"]) == n_scans - len(got)
          and int(r["scans_rejected"]) == 0 and int(r["scans_dropped"]) == 0,
          f"scans_in={r['scans_in']} feature_scans_out={r['feature_scans_out']} "
          f"feature_telegrams_out={r['feature_telegrams_out']} rejected={r['scans_rejected']} dropped={r['scans_dropped']} "
          f"host_scans_dropped={r['host_scans_dropped']}")


def main():
    # Vectors from PROTOCOL.md section 4 prove the CRC used here.
    assert telegram(0x00, bytes([0x31])) == bytes.fromhex("02000100311512")
    assert telegram(0x80, bytes([0xA0, 0x00, 0x10])) == bytes.fromhex("02800300a00010160a")
    assert len(room_scan(0)) == 732

    # The scan markers must survive optimisation as their own functions.
    nm = subprocess.run(["nm", ELF], capture_output=True, text=True).stdout
    marks = {line.split()[2]: line.split()[0] for line in nm.splitlines()
             if line.endswith((" scan_begin", " scan_end")) and " T " in line}
    check("scan_begin / scan_end symbols", len(set(marks.values())) == 2,
          ", ".join(f"{k} at 0x{v}" for k, v in sorted(marks.items())))

    tmp = tempfile.mkdtemp(prefix="lms-qemu-")
    log_path = os.path.join(tmp, "log.txt")
    base = int(os.environ.get("QEMU_PORT_BASE") or free_port_base())
    # QEMU_WAIT: the firmware starts once the three ports are connected
    # (in port order, as below), so the host port carries every byte from
    # the power-on telegram on; without it QEMU drops what the firmware
    # sends before the client connects, and the stream starts mid-telegram.
    env = dict(os.environ, QEMU_TRANSPORT="tcp", QEMU_PORT_BASE=str(base), QEMU_WAIT="1",
               QEMU_TIMEOUT=os.environ.get("QEMU_TIMEOUT", "90"))
    with open(log_path, "w") as log:
        qemu = subprocess.Popen([os.path.join(HERE, "run-qemu.sh"), ELF], env=env,
                                stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    try:
        deadline = time.monotonic() + 10
        host = connect(base + 1, deadline)
        sensor = connect(base + 2, deadline)
        control = connect(base + 3, deadline)

        first = wait_for_console(control, deadline)
        check("console answers", bool(first), (first or "").strip()[:60] + " ...")

        if STANDIN:
            plumbing(host, sensor, control)
        else:
            coprocessor(host, sensor, control)

        r1, t1 = report(control)
        time.sleep(3.0)
        r2, t2 = report(control)
        fw = (int(r2["now_us"]) - int(r1["now_us"])) / 1e6
        emu = (int(r2["emulator_us"]) - int(r1["emulator_us"])) / 1e6
        wall = t2 - t1
        # Loose on purpose: QEMU loses SysTick ticks when the host is busy
        # (measured -0.6 % idle, -3 % under load); a wrong clock would be
        # off by a factor (8 for the reference clock, 10.5 for 16 MHz).
        # Under an instrumenting TCG plugin (budgets.sh sets
        # SMOKE_NO_CLOCK_CHECK) the guest runs slower than QEMU's clock and
        # loses more (measured -10 to -26 %): reported, not checked.
        if os.environ.get("SMOKE_NO_CLOCK_CHECK"):
            print(f"skip time base (instrumented run): now_us {fw:.4f} s, "
                  f"SYS_ELAPSED {emu:.4f} s ({(fw / emu - 1) * 100:+.2f} %)")
        else:
            check("time base follows QEMU's clock", abs(fw - emu) < 0.10 * emu,
                  f"now_us advanced {fw:.4f} s while SYS_ELAPSED advanced {emu:.4f} s "
                  f"({(fw / emu - 1) * 100:+.2f} %), test's wall clock {wall:.4f} s")

        # QEMU models no cycle counter: the load figures say so (0), the
        # board's are checked at register level (regcheck.py).
        load = [int(r2[k]) for k in ("cycle_counter", "scan_poll_cycles_max", "scan_poll_cycles_last")]
        check("scan cycles: no cycle counter under QEMU, reported as 0",
              load == [0, 0, 0] or (load[0] == 1 and load[1] >= load[2] > 0),
              " ".join(f"{k}={v}" for k, v in zip(("cycle_counter", "max", "last"), load)))
        peak, size = int(r2["stack_peak"]), int(r2["stack_size"])
        check("stack peak reported", 0 < peak < size, f"{peak} of {size} bytes")
        lost = sum(int(r2[f"{side}_{k}"]) for side in ("host", "sensor")
                   for k in ("dropped", "overrun", "line_errors"))
        check("no byte lost", lost == 0,
              f"sensor queue peak {r2['sensor_peak']} B, host queue peak {r2['host_peak']} B")

        control.sendall(b"q")
        line = read_line(control)
        rc = qemu.wait(timeout=10)
        check("console q exits with 0", rc == 0 and "scans=" in line, f"exit code {rc}")
    finally:
        if qemu.poll() is None:
            os.killpg(qemu.pid, 15)
            qemu.wait(timeout=10)
    with open(log_path) as f:
        log = f.read()
    if shutil.which("defmt-print"):
        check("log decoded, ready line", " ready: " in log)
    else:
        print("skip log decoded (defmt-print not installed)")
    print("--- firmware log (reports left out) ---")
    print("\n".join(l for l in log.splitlines() if "Report {" not in l) + "\n---")
    failed = results.count(False)
    print(f"{len(results) - failed} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
