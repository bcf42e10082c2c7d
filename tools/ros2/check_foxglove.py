#!/usr/bin/env python3
"""Check host-bridge's Foxglove live view with an independent WebSocket client.

Usage:
    python3 tools/ros2/check_foxglove.py --bin target/debug/host-bridge \
        [--log FILE.log.gz] [--frames A..B] [--timeout SECONDS]
    python3 tools/ros2/check_foxglove.py --url ws://127.0.0.1:8765

With --bin, runs `host-bridge extract LOG --realtime --foxglove 127.0.0.1:0
-o OUT.jsonl` (LOG: --log, default the Intel log of
/work/shared/data/carmen, else ../shared/data/carmen beside the checkout),
reads the address it serves on from its stderr, and checks as a Foxglove
client would, with the Python `websockets` package:

* a client that offers only the older subprotocol name
  `foxglove.websocket.v1` is refused (HTTP 400), as docs/GUIDE.md says;
* offering `foxglove.sdk.v1` (and the older name), the server answers
  `foxglove.sdk.v1`, sends `serverInfo`, then `advertise` with the three
  channels /scan, /features/markers, /features: message encoding `cdr`,
  schema encoding `ros2msg`, the ROS 2 type names;
* after subscribing to /scan and /features (not /features/markers), binary
  message data (op 0x01) arrives for both subscriptions and for no other;
* every message decodes (`mcap-ros2-support`, from the advertised schema
  text alone): a LaserScan of the log's beam count, and Features whose
  lines (alpha, r) and corners (x, y) equal, as float32, the JSON Lines
  record of the same frame written by the same run (the frame is told by
  the header stamp: its index at the LMS scan period);
* SIGINT ends host-bridge with status 0 and its `--realtime` summary.

With --url, only the protocol checks run against a server already there
(`simulate --foxglove`, `scan --foxglove`, ...).

Exits 1 with the failures listed, 0 when every check passes. Needs
`websockets` and `mcap-ros2-support` (tools/ros2/requirements.txt).
"""

from __future__ import annotations

import argparse
import asyncio
import json
import re
import signal
import struct
import subprocess
import sys
import tempfile
from pathlib import Path

import websockets
from mcap.records import Schema
from mcap_ros2.decoder import DecoderFactory

ROOT = Path(__file__).resolve().parents[2]
TYPES = {
    "/scan": "sensor_msgs/msg/LaserScan",
    "/features/markers": "visualization_msgs/msg/MarkerArray",
    "/features": "lms_features_msgs/msg/Features",
}
WANTED = ("/scan", "/features")
SUBPROTOCOL = "foxglove.sdk.v1"
LEGACY = "foxglove.websocket.v1"
MESSAGE_DATA = 0x01


def default_log() -> Path:
    for base in (Path("/work/shared/data/carmen"), ROOT.parent / "shared" / "data" / "carmen"):
        log = base / "intel-corrected.log.gz"
        if log.exists():
            return log
    sys.exit("no --log given and no intel-corrected.log.gz in the shared data")


def f32(x: float) -> float:
    return struct.unpack("<f", struct.pack("<f", x))[0]


class Checks:
    """Collects failures."""

    def __init__(self) -> None:
        self.failures: list[str] = []
        self.passed = 0

    def expect(self, ok: bool, what: str) -> bool:
        if ok:
            self.passed += 1
        else:
            self.failures.append(what)
        return ok


async def legacy_refused(url: str, checks: Checks) -> None:
    """Only the older name offered: the SDK's server refuses the handshake."""
    try:
        async with websockets.connect(url, subprotocols=[LEGACY], open_timeout=5):
            checks.expect(False, f"a client offering only {LEGACY} was accepted")
    except websockets.exceptions.InvalidStatus as e:
        checks.expect(
            e.response.status_code == 400,
            f"{LEGACY} only: HTTP {e.response.status_code}, expected 400",
        )
    except websockets.exceptions.NegotiationError as e:
        checks.expect(False, f"{LEGACY} only: {e}")


async def receive(url: str, checks: Checks, per_topic: int, timeout: float) -> dict:
    """Handshake, serverInfo, advertise, subscribe; the payloads per topic."""
    got: dict[str, list[tuple[int, bytes]]] = {t: [] for t in WANTED}
    async with websockets.connect(
        url, subprotocols=[SUBPROTOCOL, LEGACY], open_timeout=10, max_size=None
    ) as ws:
        checks.expect(ws.subprotocol == SUBPROTOCOL, f"subprotocol {ws.subprotocol!r}")
        info = json.loads(await asyncio.wait_for(ws.recv(), timeout))
        checks.expect(info.get("op") == "serverInfo", f"first message {info.get('op')!r}")
        advertised: dict[str, dict] = {}
        while set(advertised) != set(TYPES):
            msg = await asyncio.wait_for(ws.recv(), timeout)
            if isinstance(msg, bytes):
                continue
            op = json.loads(msg)
            if op.get("op") == "advertise":
                advertised.update({c["topic"]: c for c in op["channels"]})
        for topic, type_name in TYPES.items():
            c = advertised[topic]
            checks.expect(c["encoding"] == "cdr", f"{topic}: encoding {c['encoding']!r}")
            checks.expect(
                c.get("schemaEncoding") == "ros2msg",
                f"{topic}: schema encoding {c.get('schemaEncoding')!r}",
            )
            checks.expect(c["schemaName"] == type_name, f"{topic}: type {c['schemaName']!r}")
        sub_ids = {i + 1: topic for i, topic in enumerate(WANTED)}
        await ws.send(
            json.dumps(
                {
                    "op": "subscribe",
                    "subscriptions": [
                        {"id": i, "channelId": advertised[t]["id"]} for i, t in sub_ids.items()
                    ],
                }
            )
        )
        loop = asyncio.get_running_loop()
        end = loop.time() + timeout
        while min(len(v) for v in got.values()) < per_topic and loop.time() < end:
            try:
                msg = await asyncio.wait_for(ws.recv(), end - loop.time())
            except asyncio.TimeoutError:
                break
            if not isinstance(msg, bytes):
                continue
            checks.expect(msg[0] == MESSAGE_DATA, f"binary op {msg[0]:#04x}")
            sub, log_time = struct.unpack_from("<IQ", msg, 1)
            topic = sub_ids.get(sub)
            if checks.expect(topic is not None, f"message for subscription {sub}"):
                got[topic].append((log_time, msg[13:]))
    for topic in WANTED:
        checks.expect(len(got[topic]) > 0, f"no message data on {topic}")
    return {"advertised": advertised, "payloads": got}


def decode(result: dict, checks: Checks) -> dict:
    """Every payload decoded from the advertised schema text."""
    factory = DecoderFactory()
    decoded = {}
    for topic, payloads in result["payloads"].items():
        c = result["advertised"][topic]
        schema = Schema(id=c["id"], name=c["schemaName"], encoding="ros2msg",
                        data=c["schema"].encode())
        decoder = factory.decoder_for("cdr", schema)
        decoded[topic] = [decoder(p) for _, p in payloads]
        checks.expect(len(decoded[topic]) == len(payloads), f"{topic}: decoding")
    return decoded


def compare_with_jsonl(decoded: dict, jsonl: Path, beams: int, checks: Checks) -> None:
    """Scans of the log's beam count; features equal to the JSON records."""
    records = [json.loads(line) for line in jsonl.read_text().splitlines()]
    for scan in decoded["/scan"]:
        checks.expect(len(scan.ranges) == beams, f"/scan: {len(scan.ranges)} ranges")
    period_ns = {180: 13_333_000, 181: 13_333_000, 360: 26_667_000, 361: 26_667_000}[beams]
    for f in decoded["/features"]:
        ns = f.header.stamp.sec * 1_000_000_000 + f.header.stamp.nanosec
        index = round(ns / period_ns)
        if not checks.expect(0 <= index < len(records), f"/features stamp {ns} ns: no frame"):
            continue
        rec = records[index]
        lines = [(f32(l.alpha), f32(l.r)) for l in f.lines]
        want = [(f32(l["alpha"]), f32(l["r"])) for l in rec["lines"]]
        checks.expect(lines == want, f"frame {index}: lines {lines} != {want}")
        corners = [(f32(c.x), f32(c.y)) for c in f.corners]
        want = [(f32(c["x"]), f32(c["y"])) for c in rec["corners"]]
        checks.expect(corners == want, f"frame {index}: corners {corners} != {want}")


def run_with_bin(args: argparse.Namespace, checks: Checks) -> None:
    log = Path(args.log) if args.log else default_log()
    out = Path(tempfile.mkdtemp(prefix="lms-foxglove-")) / "replay.jsonl"
    cmd = [args.bin, "extract", str(log), "--frames", args.frames, "--realtime",
           "--foxglove", "127.0.0.1:0", "-o", str(out)]
    proc = subprocess.Popen(cmd, stderr=subprocess.PIPE, text=True)
    url = None
    stderr: list[str] = []
    try:
        for line in proc.stderr:
            stderr.append(line)
            m = re.search(r"Foxglove live view on (ws://\S+)", line)
            if m:
                url = m.group(1)
                break
        if not checks.expect(url is not None, f"no address on stderr: {''.join(stderr)}"):
            return
        asyncio.run(legacy_refused(url, checks))
        result = asyncio.run(receive(url, checks, args.messages, args.timeout))
        proc.send_signal(signal.SIGINT)
        _, rest = proc.communicate(timeout=30)
        stderr.append(rest)
        checks.expect(proc.returncode == 0, f"host-bridge exited {proc.returncode}")
        checks.expect("stopped by a signal" in rest, f"no --realtime summary: {rest}")
        decoded = decode(result, checks)
        beams = len(decoded["/scan"][0].ranges) if decoded["/scan"] else 0
        checks.expect(beams in (180, 181, 360, 361), f"/scan: {beams} beams")
        if beams in (180, 181, 360, 361):
            compare_with_jsonl(decoded, out, beams, checks)
        print(f"check_foxglove: {url}: {len(decoded['/scan'])} scans and "
              f"{len(decoded['/features'])} feature messages received and decoded")
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bin", help="host-bridge to run (extract --realtime --foxglove)")
    parser.add_argument("--url", help="check a server already serving here instead")
    parser.add_argument("--log", help="log to replay with --bin (default: the Intel log)")
    parser.add_argument("--frames", default="0..900", help="frames to replay (default 0..900)")
    parser.add_argument("--messages", type=int, default=20,
                        help="messages to receive per subscribed topic (default 20)")
    parser.add_argument("--timeout", type=float, default=20.0, help="seconds to wait (default 20)")
    args = parser.parse_args()
    if bool(args.bin) == bool(args.url):
        parser.error("give --bin or --url")
    checks = Checks()
    if args.url:
        asyncio.run(legacy_refused(args.url, checks))
        result = asyncio.run(receive(args.url, checks, args.messages, args.timeout))
        decode(result, checks)
    else:
        run_with_bin(args, checks)
    for f in checks.failures:
        print(f"check_foxglove: FAIL: {f}", file=sys.stderr)
    print(f"check_foxglove: {checks.passed} checks passed, {len(checks.failures)} failed")
    return 1 if checks.failures else 0


if __name__ == "__main__":
    sys.exit(main())
