#!/usr/bin/env python3
"""Plot one frame of a log: the scan's points, the extracted lines and the
corners, in the sensor's frame (x forward, y left), as a PNG.

    python examples/plot_frame.py LOG OUT.png [--frame N] [--preset NAME] [--set NAME=VALUE ...]

LOG is a CARMEN log (gzip or plain) or a capture of ``host-bridge scan``;
the parameters are those ``host-bridge extract LOG`` would use (``--preset``
and ``--set`` as on its command line).
"""

import argparse
import itertools
import sys

import matplotlib

matplotlib.use("Agg")  # files only, no display needed
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import lms_features as lf  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("log", help="CARMEN log or capture")
    ap.add_argument("out", help="PNG to write")
    ap.add_argument("--frame", type=int, default=0, help="frame index (default 0)")
    ap.add_argument("--preset", default=None, help="default, v2 or paper")
    ap.add_argument("--set", action="append", default=[], metavar="NAME=VALUE", help="a parameter (repeatable)")
    args = ap.parse_args(argv)

    settings = dict(s.split("=", 1) for s in args.set)
    params = lf.Params.for_log(args.log, preset=args.preset, **settings)
    frame = next(itertools.islice(lf.read_log(args.log), args.frame, None), None)
    if frame is None:
        sys.exit(f"{args.log} has no frame {args.frame}")
    features = lf.Extractor(params).run(frame)

    valid = frame.valid & (frame.ranges < params.max_range)
    r, b = frame.ranges[valid], frame.bearings[valid]
    fig, ax = plt.subplots(figsize=(8, 8))
    ax.plot(r * np.cos(b), r * np.sin(b), ".", ms=2, color="0.6", label=f"{valid.sum()} beams")
    lines = features.lines
    for i, line in enumerate(lines):
        ax.plot([line["x0"], line["x1"]], [line["y0"], line["y1"]], "-", lw=2, label="lines" if i == 0 else None)
    corners = features.corners
    good = corners["well_conditioned"]
    ax.plot(corners["x"][good], corners["y"][good], "o", mfc="none", mec="red", ms=9, label="corners")
    ax.plot(corners["x"][~good], corners["y"][~good], "x", color="red", ms=7, label="ill-conditioned corners")
    ax.plot([0], [0], "k^", ms=8, label="sensor")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m), forward")
    ax.set_ylabel("y (m), left")
    ax.set_title(f"{frame.index}: {len(lines)} lines, {len(corners)} corners ({params!r})", fontsize=9)
    ax.legend(loc="upper right", fontsize=8)
    ax.grid(True, lw=0.3)
    fig.savefig(args.out, dpi=120, bbox_inches="tight")
    print(f"{args.out}: frame {frame.index}, {len(lines)} lines, {len(corners)} corners")


if __name__ == "__main__":
    main()
