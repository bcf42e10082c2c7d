#!/usr/bin/env python3
"""Check host-bridge's ROS 2 outputs with independent readers.

Usage:
    python3 tools/ros2/check_outputs.py --bin target/debug/host-bridge \
        [--log FILE.log.gz]... [--out DIR] [EXTRA.mcap | EXTRA_BAG_DIR]...

With --bin, writes with that host-bridge, into --out (default: a new
temporary folder), for each --log (default: every
/work/shared/data/carmen/*.log.gz, else ../shared/data/carmen beside the
checkout) and for the synthetic scene: an MCAP file (`extract -o x.mcap`),
a rosbag2 folder (`--format rosbag2`) and the JSON Lines of the same
extraction; and two live recordings from a `simulate` sensor (`scan -o
x.mcap`, `coprocessor -o x.mcap`). Then, for every MCAP file (those, and
each EXTRA.mcap):

* the Python `mcap` reader opens it (header profile `ros2`, a summary with
  statistics and chunk indexes, every chunk zstd) and `mcap-ros2-support`
  decodes every message of every channel from the schema in the file
  (schema encoding `ros2msg`, message encoding `cdr`);
* the decoded `/features` equal the JSON Lines of the same run, value for
  value (every float as the same float32), frame by frame, and every
  marker array starts with a DELETEALL marker;

and for every rosbag2 folder (those, and each EXTRA_BAG_DIR), `rosbags`
reads metadata.yaml and deserialises every message, with the messages of
ros2/lms_features_msgs/msg/ registered in its type store.

Exits 1 with the failures listed, 0 when every check passes. Needs the
packages of tools/ros2/requirements.txt.
"""

from __future__ import annotations

import argparse
import json
import struct
import subprocess
import sys
import tempfile
from pathlib import Path

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.rosbag2 import Reader as BagReader
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

ROOT = Path(__file__).resolve().parents[2]
MSG_DIR = ROOT / "ros2" / "lms_features_msgs" / "msg"
TOPICS = {
    "/scan": "sensor_msgs/msg/LaserScan",
    "/features/markers": "visualization_msgs/msg/MarkerArray",
    "/features": "lms_features_msgs/msg/Features",
}
DELETEALL = 3


def f32(x: float | None) -> float | None:
    """The float32 nearest x (None stays None)."""
    if x is None:
        return None
    return struct.unpack("<f", struct.pack("<f", x))[0]


def same(a: float | None, b: float | None) -> bool:
    """Equal as float32, NaN equal to NaN and to a JSON null."""
    a, b = f32(a), f32(b)
    if a is None or b is None or a != a or b != b:
        return (a is None or a != a) and (b is None or b != b)
    return a == b


class Checks:
    """Collects failures."""

    def __init__(self) -> None:
        self.failures: list[str] = []
        self.passed = 0

    def expect(self, ok: bool, what: str) -> None:
        if ok:
            self.passed += 1
        else:
            self.failures.append(what)


def run(cmd: list[str]) -> None:
    print("+", " ".join(cmd), flush=True)
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)


def default_logs() -> list[Path]:
    for d in (Path("/work/shared/data/carmen"), ROOT.parent / "shared" / "data" / "carmen"):
        logs = sorted(d.glob("*.log.gz"))
        if logs:
            return logs
    return []


def write_outputs(binary: str, logs: list[Path], out: Path) -> list[tuple[Path, Path, Path]]:
    """(mcap, rosbag2 folder, jsonl) for each log and for the scene."""
    made = []
    inputs: list[tuple[str, list[str]]] = [(p.name.split(".")[0], [str(p)]) for p in logs]
    inputs.append(("scene", ["--count", "20"]))
    for name, args in inputs:
        mcap, bag, jsonl = out / f"{name}.mcap", out / f"{name}_bag", out / f"{name}.jsonl"
        run([binary, "extract", *args, "-o", str(mcap)])
        run([binary, "extract", *args, "-o", str(bag), "--format", "rosbag2"])
        run([binary, "extract", *args, "-o", str(jsonl)])
        made.append((mcap, bag, jsonl))
    return made


def write_recordings(binary: str, out: Path) -> list[Path]:
    """`scan -o` and `coprocessor -o` recordings from a `simulate` sensor."""
    sim = subprocess.Popen(
        [binary, "simulate", "--quit-after", "60"],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    try:
        pty = sim.stdout.readline().strip()
        scan, cop = out / "live-scan.mcap", out / "live-coprocessor.mcap"
        run([binary, "scan", "--port", pty, "--scans", "30", "-o", str(scan)])
        run([binary, "coprocessor", "--sensor", pty, "--link", str(out / "cop-link"),
             "--status-every", "0", "--quit-after", "2", "-o", str(cop)])
        return [scan, cop]
    finally:
        sim.terminate()
        sim.wait()


def check_features(c: Checks, where: str, msg, rec: dict) -> None:
    """One decoded Features message against its JSON Lines record."""
    c.expect(len(msg.lines) == len(rec["lines"]), f"{where}: line count")
    for i, (m, j) in enumerate(zip(msg.lines, rec["lines"])):
        cov = [x for row in j["cov"] for x in row]
        ends = [x for p in j["endpoints"] for x in p]
        ok = (
            same(m.alpha, j["alpha"])
            and same(m.r, j["r"])
            and all(same(a, b) for a, b in zip(m.covariance, cov))
            and (m.first_beam, m.last_beam, m.points) == (j["first"], j["last"], j["points"])
            and same(m.chi2, j["chi2"])
            and all(same(a, b) for a, b in zip(m.endpoints, ends))
        )
        c.expect(ok, f"{where}: line {i} differs from the JSON Lines")
    c.expect(len(msg.corners) == len(rec["corners"]), f"{where}: corner count")
    for i, (m, j) in enumerate(zip(msg.corners, rec["corners"])):
        cov = [x for row in j["cov"] for x in row]
        ok = (
            same(m.x, j["x"])
            and same(m.y, j["y"])
            and all(same(a, b) for a, b in zip(m.covariance, cov))
            and same(m.angle_deg, j["angle_deg"])
            and bool(m.well_conditioned) == j["well_conditioned"]
            and (m.line_a, m.line_b) == (j["line_a"], j["line_b"])
        )
        c.expect(ok, f"{where}: corner {i} differs from the JSON Lines")
    c.expect(list(msg.edge_points) == rec["edges"], f"{where}: edge points")
    stats = {k: getattr(msg.stats, k) for k in rec["stats"]}
    c.expect(stats == rec["stats"], f"{where}: stats {stats} != {rec['stats']}")


def check_mcap(c: Checks, path: Path, jsonl: Path | None) -> None:
    """Open, check the summary, decode every message (see the module doc)."""
    records = []
    if jsonl is not None:
        records = [json.loads(line) for line in jsonl.read_text().splitlines()]
    counts = {t: 0 for t in TOPICS}
    with path.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        c.expect(reader.get_header().profile == "ros2", f"{path}: profile is not ros2")
        summary = reader.get_summary()
        c.expect(summary is not None, f"{path}: no summary")
        if summary is None:
            return
        c.expect(summary.statistics is not None, f"{path}: no statistics")
        c.expect(len(summary.chunk_indexes) > 0, f"{path}: no chunk index")
        c.expect(
            all(ci.compression == "zstd" for ci in summary.chunk_indexes),
            f"{path}: a chunk is not zstd",
        )
        for ch in summary.channels.values():
            schema = summary.schemas[ch.schema_id]
            c.expect(TOPICS.get(ch.topic) == schema.name, f"{path}: {ch.topic} is {schema.name}")
            c.expect(ch.message_encoding == "cdr", f"{path}: {ch.topic} not cdr")
            c.expect(schema.encoding == "ros2msg", f"{path}: {schema.name} not ros2msg")
        frame = 0
        for _schema, channel, message, msg in reader.iter_decoded_messages(log_time_order=False):
            counts[channel.topic] += 1
            where = f"{path.name} {channel.topic} #{counts[channel.topic] - 1}"
            stamp = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec if channel.topic != "/features/markers" else None
            if stamp is not None:
                c.expect(stamp == message.log_time, f"{where}: header stamp != log time")
            if channel.topic == "/features/markers":
                c.expect(
                    len(msg.markers) > 0 and msg.markers[0].action == DELETEALL,
                    f"{where}: does not start with DELETEALL",
                )
            elif channel.topic == "/features" and records:
                if frame < len(records):
                    check_features(c, where, msg, records[frame])
                frame += 1
            elif channel.topic == "/scan":
                c.expect(len(msg.ranges) >= 3, f"{where}: {len(msg.ranges)} ranges")
        if records:
            c.expect(frame == len(records), f"{path}: {frame} features, {len(records)} JSON records")
    c.expect(
        len(set(counts.values())) == 1 and counts["/scan"] > 0,
        f"{path}: messages per topic {counts}",
    )
    print(f"{path}: {sum(counts.values())} messages decoded ({counts['/scan']} frames)")


def typestore_with_ours():
    """The ROS 2 Humble type store with lms_features_msgs registered."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    types = {}
    for msg in sorted(MSG_DIR.glob("*.msg")):
        types.update(get_types_from_msg(msg.read_text(), f"lms_features_msgs/msg/{msg.stem}"))
    store.register(types)
    return store


def check_bag(c: Checks, path: Path) -> None:
    """rosbags reads metadata.yaml and deserialises every message."""
    store = typestore_with_ours()
    n = 0
    with BagReader(path) as reader:
        topics = {con.topic: con.msgtype for con in reader.connections}
        c.expect(topics == TOPICS, f"{path}: topics {topics}")
        per = {}
        for con, timestamp, raw in reader.messages():
            msg = store.deserialize_cdr(raw, con.msgtype)
            per[con.topic] = per.get(con.topic, 0) + 1
            if con.topic != "/features/markers":
                stamp = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
                c.expect(stamp == timestamp, f"{path}: {con.topic} stamp != time")
            n += 1
        c.expect(n == reader.message_count and n > 0, f"{path}: {n} of {reader.message_count}")
        c.expect(
            all(per.get(con.topic) == con.msgcount for con in reader.connections),
            f"{path}: counts {per} differ from metadata.yaml",
        )
    print(f"{path}: {n} messages deserialised by rosbags")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--bin", help="host-bridge binary: write the outputs to check")
    ap.add_argument("--log", action="append", type=Path, help="CARMEN log (repeatable)")
    ap.add_argument("--out", type=Path, help="folder for the outputs (default: temporary)")
    ap.add_argument("extra", nargs="*", type=Path, help="more .mcap files or rosbag2 folders")
    args = ap.parse_args()
    c = Checks()
    with tempfile.TemporaryDirectory(prefix="lms-ros2-") as tmp:
        out = args.out or Path(tmp)
        out.mkdir(parents=True, exist_ok=True)
        made, live = [], []
        if args.bin:
            made = write_outputs(args.bin, args.log or default_logs(), out)
            live = write_recordings(args.bin, out)
        for mcap, bag, jsonl in made:
            check_mcap(c, mcap, jsonl)
            check_mcap(c, next(bag.glob("*.mcap")), jsonl)
            check_bag(c, bag)
        for p in live:
            check_mcap(c, p, None)
        for p in args.extra:
            if p.is_dir():
                check_bag(c, p)
            else:
                check_mcap(c, p, None)
        if not made and not args.extra:
            print("nothing to check: give --bin or paths", file=sys.stderr)
            return 2
    for f in c.failures[:50]:
        print("FAIL:", f, file=sys.stderr)
    print(f"{c.passed} checks passed, {len(c.failures)} failed")
    return 1 if c.failures else 0


if __name__ == "__main__":
    sys.exit(main())
