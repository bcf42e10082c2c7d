#!/usr/bin/env python3
"""Per-frame time of ``Extractor.run`` from Python against the Rust pipeline's.

    python bench/per_frame.py [LOG] [--repeats N] [--max-ratio R]

Python: ``Extractor.run(ranges, resolution_deg, fov_deg)`` on every frame of
the log (ranges as float32 numpy arrays read beforehand with ``read_log``,
the parameters ``host-bridge extract`` uses for the log), timed around the
whole loop: the call, the input checks, the GIL's release and the numpy
arrays of the result included. Rust: ``host-bridge extract LOG -o
/dev/null``, whose summary line times ``Extractor::run_traced`` alone (the
same call ``run`` makes) over the same frames. Each side runs ``--repeats``
times, interleaved; the best of each is compared. With ``--max-ratio`` the
exit status is 1 when Python/Rust exceeds it.

LOG defaults to csail-corrected of the shared data (``LMS_DATA_DIR``); the
binary is ``HOST_BRIDGE`` (default target/release/host-bridge of the repository).
"""

import argparse
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import lms_features as lf

REPO = Path(__file__).resolve().parents[2]
DATA = Path(os.environ.get("LMS_DATA_DIR", REPO.parent / "shared" / "data"))
HOST_BRIDGE = os.environ.get("HOST_BRIDGE", str(REPO / "target" / "release" / "host-bridge"))


def rust_per_frame(log):
    """Seconds per frame of the Rust pipeline, from extract's summary line."""
    run = subprocess.run([HOST_BRIDGE, "extract", str(log), "-o", os.devnull], capture_output=True, text=True)
    if run.returncode != 0:
        sys.exit(run.stderr)
    m = re.search(r": (\d+) frames.*; pipeline ([\d.]+) ms", run.stderr)
    if not m:
        sys.exit(f"no summary line in: {run.stderr}")
    return float(m.group(2)) / 1e3 / int(m.group(1))


def python_per_frame(ex, frames):
    """Seconds per frame of ``Extractor.run`` over ``frames``."""
    start = time.perf_counter()
    for ranges, resolution, fov in frames:
        ex.run(ranges, resolution, fov)
    return (time.perf_counter() - start) / len(frames)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("log", nargs="?", default=str(DATA / "carmen" / "csail-corrected.log.gz"))
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--max-ratio", type=float, default=None)
    args = ap.parse_args()

    frames = [(f.ranges, f.resolution_deg, f.fov_deg) for f in lf.read_log(args.log)]
    ex = lf.Extractor(lf.Params.for_log(args.log))
    python_per_frame(ex, frames)  # warm-up
    py, rust = [], []
    for _ in range(args.repeats):
        rust.append(rust_per_frame(args.log))
        py.append(python_per_frame(ex, frames))
    ratio = min(py) / min(rust)
    print(f"{Path(args.log).name}: {len(frames)} frames, best of {args.repeats}")
    print(f"  Rust   Extractor::run_traced (host-bridge extract): {min(rust) * 1e6:8.1f} µs/frame")
    print(f"  Python Extractor.run (numpy float32 in, arrays out): {min(py) * 1e6:8.1f} µs/frame")
    print(f"  Python / Rust: {ratio:.3f}")
    if args.max_ratio is not None and ratio > args.max_ratio:
        print(f"  over the goal of {args.max_ratio}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
