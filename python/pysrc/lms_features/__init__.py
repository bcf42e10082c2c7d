"""SICK LMS 2xx laser scans to SLAM features: lines with covariance, corners.

The Python face of ``lms-core`` (adaptive line smoothing in a modified scale
space) and of ``host-bridge``'s readers:

* ``Params`` — the pipeline's parameters: a preset (``"default"``, ``"v2"``,
  ``"paper"``) and any parameter by name (``PARAMETERS``).
* ``Extractor(params).run(ranges, resolution_deg, fov_deg)`` — the features
  of one scan (``Features``: numpy structured arrays of lines and corners,
  segments, edges, stats).
* ``read_log(path)`` — the scans (``Frame``) of a CARMEN log or a capture.
* ``extract_log(path)`` — per frame, the dict that ``host-bridge extract``
  writes as JSON for it.

docs/PYTHON.md in the repository is the guide.
"""

from ._native import (
    CORNER_DTYPE,
    LINE_DTYPE,
    PARAMETERS,
    PRESETS,
    SEGMENT_DTYPE,
    STATS,
    Extractor,
    Features,
    Frame,
    LogExtraction,
    LogReader,
    Params,
    __version__,
    extract_log,
    read_log,
)

__all__ = [
    "CORNER_DTYPE",
    "LINE_DTYPE",
    "PARAMETERS",
    "PRESETS",
    "SEGMENT_DTYPE",
    "STATS",
    "Extractor",
    "Features",
    "Frame",
    "LogExtraction",
    "LogReader",
    "Params",
    "__version__",
    "extract_log",
    "read_log",
]
