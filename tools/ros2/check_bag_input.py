#!/usr/bin/env python3
"""Independent check of ROS 2 bag input: the features `host-bridge extract`
finds in a ROS 2 bag are those it finds in the CARMEN log the bag was
written from.

The bag is written with the `rosbags` package (not with host-bridge's own
code): a rosbag2 folder with MCAP storage holding one
`sensor_msgs/msg/LaserScan` topic, `/scan`, one message per FLASER line of
the log (LMS geometry: angle_min -90 deg or -50 deg, angle_increment 1,
0.5 or 0.25 deg; ranges in metres as float32; range_min 0, range_max the
largest valid range of the log's unit: 81.82 m in cm, 32.758 m in mm;
stamp from the line's IPC time; frame_id "laser"). Then `host-bridge
extract` runs on the log, on the folder and on the folder's .mcap file, and
every JSON record must be identical except the log's `pose` (a bag has
none). The folder's .mcap file is also copied into one with zstd-compressed
chunks by the Python `mcap` writer, and checked the same way.

`--scans N` first repeats the log's FLASER lines up to N scans (a plain log
in the work folder, the input of the memory and time figures of
docs/GUIDE.md).

Usage (needs `pip install -r tools/ros2/requirements.txt`):
    python3 tools/ros2/check_bag_input.py [--log LOG] [--bin HOST_BRIDGE] [--work DIR] [--scans N]
"""

import argparse
import json
import math
import shutil
import subprocess
import sys
from pathlib import Path
import gzip

import numpy as np
from mcap.reader import make_reader
from mcap.writer import CompressionType
from mcap.writer import Writer as McapWriter
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

ROOT = Path(__file__).resolve().parents[2]
DEFAULT_LOG = Path("/work/shared/data/carmen/csail-corrected.log.gz")

# Beam count -> (field of view in degrees, resolution in degrees); 180 and
# 360 are CARMEN's 181 and 361 without the last beam.
GEOMETRY = {
    181: (180, 1.0),
    180: (180, 1.0),
    361: (180, 0.5),
    360: (180, 0.5),
    101: (100, 1.0),
    201: (100, 0.5),
    401: (100, 0.25),
}


def flaser_lines(path):
    opener = gzip.open if path.read_bytes()[:2] == b"\x1f\x8b" else open
    with opener(path, "rt") as f:
        for line in f:
            words = line.split()
            if words and words[0] == "FLASER":
                yield words


def decimals(text):
    return len(text.split(".", 1)[1]) if "." in text else 0


def unit_of(path):
    """mm if at least 1/4 of the ranges show 3 decimals (as `--unit auto`)."""
    total = three = 0
    for words in flaser_lines(path):
        n = int(words[1])
        for t in words[2 : 2 + n]:
            total += 1
            three += decimals(t) >= 3
    return "mm" if total and 4 * three >= total else "cm"


def write_bag(log, folder):
    typestore = get_typestore(Stores.ROS2_HUMBLE)
    LaserScan = typestore.types["sensor_msgs/msg/LaserScan"]
    Header = typestore.types["std_msgs/msg/Header"]
    Time = typestore.types["builtin_interfaces/msg/Time"]
    range_max = 32.758 if unit_of(log) == "mm" else 81.82
    count = 0
    with Writer(folder, version=8, storage_plugin=StoragePlugin.MCAP) as writer:
        conn = writer.add_connection("/scan", LaserScan.__msgtype__, typestore=typestore)
        for words in flaser_lines(log):
            n = int(words[1])
            fov, res = GEOMETRY[n]
            ranges = np.array([float(t) for t in words[2 : 2 + n]], dtype=np.float32)
            stamp = float(words[2 + n + 6])
            sec = math.floor(stamp)
            nanosec = min(int(round((stamp - sec) * 1e9)), 999_999_999)
            angle_min = -math.radians(fov / 2)
            step = math.radians(res)
            msg = LaserScan(
                header=Header(stamp=Time(sec=sec, nanosec=nanosec), frame_id="laser"),
                angle_min=angle_min,
                angle_max=angle_min + (n - 1) * step,
                angle_increment=step,
                time_increment=0.0,
                scan_time=0.0,
                range_min=0.0,
                range_max=range_max,
                ranges=ranges,
                intensities=np.array([], dtype=np.float32),
            )
            data = typestore.serialize_cdr(msg, LaserScan.__msgtype__)
            writer.write(conn, sec * 1_000_000_000 + nanosec, data)
            count += 1
    return count


def repeat_log(log, scans, out):
    """The FLASER lines of `log` repeated up to `scans` lines, as plain text."""
    lines = [" ".join(words) + "\n" for words in flaser_lines(log)]
    with open(out, "w") as f:
        for i in range(scans):
            f.write(lines[i % len(lines)])
    return out


def rechunk_zstd(src, dst):
    """The messages of the MCAP file `src` into `dst`, zstd-compressed chunks."""
    with open(src, "rb") as f, open(dst, "wb") as out:
        writer = McapWriter(out, compression=CompressionType.ZSTD)
        writer.start(profile="ros2", library="check_bag_input")
        schemas, channels = {}, {}
        for schema, channel, message in make_reader(f).iter_messages(log_time_order=False):
            if schema.id not in schemas:
                schemas[schema.id] = writer.register_schema(schema.name, schema.encoding, schema.data)
            if channel.id not in channels:
                channels[channel.id] = writer.register_channel(
                    channel.topic, channel.message_encoding, schemas[schema.id], channel.metadata
                )
            writer.add_message(
                channels[channel.id], message.log_time, message.data, message.publish_time, message.sequence
            )
        writer.finish()
    return dst


def extract(binary, source, out):
    run = subprocess.run(
        [str(binary), "extract", str(source), "-o", str(out)],
        capture_output=True,
        text=True,
    )
    if run.returncode != 0:
        sys.exit(f"FAIL: extract {source}: {run.stderr.strip()}")
    records = [json.loads(line) for line in out.read_text().splitlines()]
    return records, run.stderr


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--log", type=Path, default=DEFAULT_LOG)
    ap.add_argument("--bin", type=Path, default=ROOT / "target/release/host-bridge")
    ap.add_argument("--work", type=Path, default=Path("/tmp/lms/ros2-check"))
    ap.add_argument("--scans", type=int, help="repeat the log's scans up to this many first")
    args = ap.parse_args()
    if not args.bin.exists():
        sys.exit(f"FAIL: {args.bin} does not exist (cargo build --release -p host-bridge)")
    shutil.rmtree(args.work, ignore_errors=True)
    args.work.mkdir(parents=True)
    if args.scans:
        args.log = repeat_log(args.log, args.scans, args.work / "log")
    folder = args.work / "bag"
    scans = write_bag(args.log, folder)
    mcaps = sorted(folder.glob("*.mcap"))
    if len(mcaps) != 1:
        sys.exit(f"FAIL: expected one .mcap file in {folder}, found {mcaps}")

    zstd = rechunk_zstd(mcaps[0], args.work / "zstd.mcap")
    log_records, _ = extract(args.bin, args.log, args.work / "log.jsonl")
    sources = [("rosbag2 folder", folder), ("MCAP file", mcaps[0]), ("zstd MCAP file", zstd)]
    for name, source in sources:
        bag_records, stderr = extract(args.bin, source, args.work / f"{source.name}.jsonl")
        if len(bag_records) != len(log_records) or len(bag_records) != scans:
            sys.exit(
                f"FAIL: {name}: {len(bag_records)} records, the log {len(log_records)}, "
                f"{scans} scans written"
            )
        for a, b in zip(log_records, bag_records):
            a = {k: v for k, v in a.items() if k != "pose"}
            b = {k: v for k, v in b.items() if k != "pose"}
            if a != b:
                diff = sorted(k for k in a.keys() | b.keys() if a.get(k) != b.get(k))
                sys.exit(f"FAIL: {name}: frame {a.get('frame')} differs in {diff}")
        if "invalid beams" not in stderr:
            sys.exit(f"FAIL: {name}: no invalid-beam summary on stderr:\n{stderr}")
        print(f"ok: {name} {source}: {scans} scans, records identical to {args.log.name}")


if __name__ == "__main__":
    main()
