"""SICK LMS 2xx laser scans to SLAM features: lines with covariance, corners.

Type stubs of the extension module (``lms_features._native``), which the
package re-exports. docs/PYTHON.md in the repository is the guide.
"""

import os
from typing import Any, Dict, Iterator, List, Literal, Optional, Tuple, Union, final

import numpy as np
import numpy.typing as npt

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

__version__: str

PARAMETERS: Tuple[Tuple[str, str, str], ...]
"""``(name, unit, meaning)`` of every parameter of ``Params``, in field order."""

PRESETS: Dict[str, str]
"""Preset name (``"default"``, ``"v3.2"``, ``"v3.1"``, ``"v3.0"``, ``"v2"``, ``"paper"``) → its one-line summary."""

STATS: Tuple[Tuple[str, str], ...]
"""``(name, meaning)`` of every counter of ``Features.stats``, in order."""

LINE_DTYPE: np.dtype[np.void]
"""Structured dtype of ``Features.lines``: ``alpha``, ``r`` (the line
``x·cos(alpha) + y·sin(alpha) = r``; rad, m), ``cov_aa``, ``cov_ar``,
``cov_rr`` (covariance of (alpha, r)), ``first``, ``last`` (beams of the
fitted segment, inclusive), ``points`` (valid points fitted), ``chi2`` (fit
quality, about 1 for a true line), ``x0``, ``y0``, ``x1``, ``y1`` (first and
last points projected onto the line, m). Reals ``float32``, beams ``uint16``."""

CORNER_DTYPE: np.dtype[np.void]
"""Structured dtype of ``Features.corners``: ``x``, ``y`` (m; x forward, y
left), ``cov_xx``, ``cov_xy``, ``cov_yy`` (m²), ``angle_deg`` (between the
lines, 0..90), ``well_conditioned`` (``angle_deg >= min_corner_angle_deg``),
``line_a``, ``line_b`` (indices into ``lines``)."""

SEGMENT_DTYPE: np.dtype[np.void]
"""Structured dtype of ``Features.segments``: ``first``, ``last`` (beams, inclusive)."""

_Setting = Union[float, int, bool, str]
_Unit = Literal["auto", "cm", "mm"]
_PathLike = Union[str, "os.PathLike[str]"]

@final
class Params:
    """Parameters of the pipeline: a preset and any parameter by name.

    ``Params(preset="default", **settings)``: the preset's values
    (``"default"``, ``"v3.2"``, ``"v3.1"``, ``"v3.0"``, ``"v2"`` or ``"paper"``, as ``host-bridge --preset``),
    then each setting by the parameter's name (``PARAMETERS`` lists every
    one with its unit and meaning). A value is a number (``float("inf")``
    where the parameter allows it), a whole number, a bool, or text as
    ``--set NAME=VALUE`` takes it. Every parameter reads as an attribute;
    reals read as the shortest decimal of their ``float32``. Immutable and
    hashable: ``replace(**settings)`` gives a changed copy.

    Raises ``ValueError`` naming the parameter for an unknown name, a value
    of the wrong kind or out of range, and for an unknown preset; a value
    of another Python type raises ``TypeError``.
    """

    def __new__(cls, preset: str = "default", **settings: _Setting) -> "Params": ...
    @staticmethod
    def for_log(
        path: _PathLike, preset: Optional[str] = None, unit: _Unit = "auto", **settings: _Setting
    ) -> "Params":
        """The parameters ``host-bridge extract PATH`` uses for the log at
        ``path``: σ and max_range from its data (its unit and quantisation
        step, under ``preset`` too), then ``settings``, as ``--preset`` and
        ``--set`` give them. A capture's parameters are the preset's.
        ``unit``: the unit of the log's error codes (``--unit``). Fill values
        caught by max_range give a ``UserWarning``, as ``extract`` warns."""
    def replace(self, **settings: _Setting) -> "Params":
        """A copy with ``settings`` applied (checked as by the constructor)."""
    def to_dict(self) -> Dict[str, Union[float, int, bool]]:
        """Every parameter by name, in ``PARAMETERS`` order."""
    def __eq__(self, other: object, /) -> bool: ...
    def __hash__(self) -> int: ...

    sigma: float
    """Range noise standard deviation of the smoothing filter and the segmentation (m)."""
    q: float
    """Process noise of the smoothing filter, the second scale parameter (m²)."""
    iterations: int
    """Smoothing passes, the first scale parameter (1..=1000)."""
    tau: float
    """Segmentation gate on D: a window above it breaks a segment."""
    min_points: int
    """Smallest segment kept (beams, at least 3)."""
    max_chi2: float
    """Largest chi-square of an accepted line."""
    min_length: float
    """Shortest accepted line, endpoint to endpoint (m)."""
    fit_shared_points: bool
    """Fit a corner beam shared by two segments into both lines."""
    merge: bool
    """Merge consecutive lines that agree."""
    merge_gap_beams: int
    """Most valid beams between two lines that may merge."""
    merge_gate: float
    """Gate of the merge test (chi², 2 dof)."""
    corner_gap: float
    """Largest gap between facing endpoints of two lines made a corner (m)."""
    min_corner_angle_deg: float
    """Smallest angle between two lines for a well-conditioned corner (deg, 0..=90)."""
    split_depth: int
    """Split before reject: times a segment that is not one line may be split (0 off, at most 16)."""
    max_range: float
    """Largest true range: a beam at or beyond it is invalid (m; inf: no limit)."""
    merge_collinear: bool
    """Merge touching, nearly collinear lines whose union fits."""
    max_alpha_sd_deg: float
    """Largest standard deviation of a line's angle; a less certain line is dropped (deg; inf: keep all)."""
    grazing_noise: float
    """Grazing-incidence term of the window noise (0 off)."""
    same_turn_windows: bool
    """Windows of one mirror turn's beams in the interleaved 0.5° and 0.25° modes."""
    fit_sigma: float
    """Range noise of the line fits (m; 0: sigma)."""
    per_turn: bool
    """Extract each mirror turn alone and fuse their lines (interleaved modes)."""
    bridge_merge: bool
    """Merge two accepted lines across the rejected segments between them when their union fits."""
    footprint: float
    """Beam-footprint term of the fits' range noise, sigma² + (footprint·d·tan θ)² (rad; 0 off)."""
    arc_chain: int
    """Fewest touching lines turning the same way that are dropped as an arc (0 off, else at least 2)."""
    arc_min_turn_deg: float
    """Smallest turn between consecutive lines of an arc (deg)."""
    arc_max_turn_deg: float
    """Largest turn between consecutive lines of an arc (deg, at most 180)."""
    split_budget: int
    """Work bound of split before reject per frame, in beams tested (0: no bound)."""
    merge_anchor_gate: float
    """A merge keeps the union line within this of the larger line's own (chi², 2 dof; inf: no test)."""
    turn_offsets: bool
    """Line fits' chi-square allows an offset between interleaved mirror turns."""
    merge_f_test: float
    """Nested-model F test of the merges (0 off)."""
    arc_pairs: bool
    """Drop a pair of touching lines that a circle explains better."""
    merge_own_beams: bool
    """Merges refit the two lines' own beams, leaving out the beams between them."""
    footprint_choice: bool
    """Each line takes the fit with or without the footprint term whose noise model its beams are likelier under."""

@final
class Frame:
    """One scan of a log or a capture, as ``read_log`` yields it.

    ``ranges`` are metres (``float32``) with ``+inf`` where the beam has no
    range (an LMS error code or a zero reading; ``invalid`` says which). A
    log's fill values stay as recorded, for ``max_range`` to catch.
    ``Extractor.run(frame)`` runs the scan as it was read.
    """

    @property
    def index(self) -> int:
        """Index of the scan in its file (``FLASER`` lines or capture records), from 0."""
    @property
    def n(self) -> int:
        """Number of beams."""
    def __len__(self) -> int: ...
    @property
    def ranges(self) -> npt.NDArray[np.float32]:
        """Ranges (m, ``float32``), ``+inf`` where the beam has no range."""
    @property
    def valid(self) -> npt.NDArray[np.bool_]:
        """``True`` where the beam has a range."""
    @property
    def invalid(self) -> Dict[int, str]:
        """Why each beam without a range has none: ``{beam: reason}``."""
    @property
    def bearings(self) -> npt.NDArray[np.float32]:
        """Bearing of every beam (rad, ``float32``): 0 straight ahead, counter-clockwise."""
    @property
    def resolution_deg(self) -> float:
        """Angle between beams (degrees): 1, 0.5 or 0.25."""
    @property
    def fov_deg(self) -> int:
        """Field of view (degrees): 180 or 100."""
    @property
    def pose(self) -> Optional[Tuple[float, float, float]]:
        """Laser pose ``(x, y, θ)`` of a log's line (m, m, rad); ``None`` for a capture."""
    @property
    def line(self) -> Optional[int]:
        """Line of the log (from 1); ``None`` for a capture."""
    @property
    def time_us(self) -> Optional[int]:
        """Time of a capture's record (µs from its start); ``None`` for a log."""

@final
class Features:
    """The features of one scan, as ``Extractor.run`` gives them.

    ``lines``, ``corners`` and ``segments`` are numpy structured arrays
    (``LINE_DTYPE``, ``CORNER_DTYPE``, ``SEGMENT_DTYPE``) in scan order;
    reals are the pipeline's ``float32`` values.
    """

    @property
    def lines(self) -> npt.NDArray[np.void]:
        """Accepted lines (``LINE_DTYPE``): ``x·cos(alpha) + y·sin(alpha) = r``."""
    @property
    def corners(self) -> npt.NDArray[np.void]:
        """Corners between consecutive lines (``CORNER_DTYPE``)."""
    @property
    def segments(self) -> npt.NDArray[np.void]:
        """Segments (``SEGMENT_DTYPE``): runs of beams ``first..=last``."""
    @property
    def edges(self) -> npt.NDArray[np.uint16]:
        """Edge points (beam indices), ascending."""
    @property
    def stats(self) -> Dict[str, int]:
        """What the run dropped or rejected: ``{name: count}`` in ``STATS`` order."""
    @property
    def smoothed(self) -> npt.NDArray[np.float32]:
        """Smoothed ranges after the last pass (m), NaN where the beam has no range."""
    @property
    def mahalanobis(self) -> npt.NDArray[np.float32]:
        """``D`` of the last pass per window of beams ``i..=i+2`` (``n − 2`` values), ``+inf`` where invalid."""

@final
class Extractor:
    """Runs the pipeline on scans, one at a time.

    ``Extractor(params=None)``: with ``params``, or the defaults. ``run``
    releases the GIL while the pipeline runs, so that other threads go on;
    an extractor may be shared by several threads, and runs their calls one
    after the other (one extractor per thread runs them side by side).
    """

    def __new__(cls, params: Optional[Params] = None) -> "Extractor": ...
    @property
    def params(self) -> Params:
        """The parameters it runs with."""
    def run(
        self,
        ranges: Union[npt.NDArray[np.float32], npt.NDArray[np.float64], List[float], Tuple[float, ...], Frame],
        resolution_deg: float = 0.5,
        fov_deg: float = 180.0,
    ) -> Features:
        """Features of one scan.

        ``ranges``: metres, a one-dimensional numpy array of ``float32`` or
        ``float64`` (read in place) or a list of numbers, one per beam from
        the right (−fov/2) counter-clockwise; ``0`` or ``+inf`` for a beam
        without a range. ``resolution_deg`` and ``fov_deg`` name the LMS
        variant: 180° at 1° or 0.5°, 100° at 1°, 0.5° or 0.25° (a 180° scan
        may lack its last beam, as in CARMEN logs). ``ranges`` may also be a
        ``Frame`` of ``read_log``, run as read (the other arguments are then
        ignored).

        Raises ``ValueError`` for NaN or a negative range (naming the beam),
        a length that does not fit the variant, or a variant the LMS does
        not have; ``TypeError`` for another dtype or a value that is not a
        number.
        """

@final
class LogReader(Iterator[Frame]):
    """The scans of a file, one ``Frame`` at a time (``read_log``), read
    ahead in a thread of its own; usable from any thread."""

    def __iter__(self) -> "LogReader": ...
    def __next__(self) -> Frame: ...
    @property
    def source(self) -> str:
        """The file and what it is, e.g. ``"…/csail.log.gz (CARMEN log, cm ranges …)"``."""

@final
class LogExtraction(Iterator[Dict[str, Any]]):
    """Each frame's record as ``host-bridge extract`` writes it
    (``extract_log``), extracted ahead in a thread of its own; usable from
    any thread."""

    def __iter__(self) -> "LogExtraction": ...
    def __next__(self) -> Dict[str, Any]: ...
    @property
    def params(self) -> Params:
        """The parameters the frames are extracted with."""
    @property
    def source(self) -> str:
        """The file and what it is."""

def read_log(path: _PathLike, unit: _Unit = "auto") -> LogReader:
    """Read the scans of ``path``: a CARMEN log (gzip or plain) or a capture
    recorded by ``host-bridge scan``, streamed, as ``host-bridge`` reads it.

    ``unit`` is the unit of a log's LMS error codes: ``"auto"`` (decided
    from the log), ``"cm"`` or ``"mm"`` (``--unit``). Yields a ``Frame`` per
    scan. Raises ``FileNotFoundError``/``OSError`` for a file that cannot be
    read, ``ValueError`` for a damaged scan (after the scans before it) or a
    file without scans; a file cut short ends with a ``UserWarning``.
    """

def extract_log(path: _PathLike, params: Optional[Params] = None, unit: _Unit = "auto") -> LogExtraction:
    """Extract the features of every scan of ``path`` and yield, per frame,
    a dict with exactly the keys and values of the JSON object that
    ``host-bridge extract PATH`` writes for it: ``frame``, ``n``,
    ``ranges``, ``smoothed``, ``mahalanobis``, ``edges``, ``segments``,
    ``lines``, ``corners``, ``stats`` and (for a log) ``pose``; ``None``
    where the JSON has ``null``. A real is the ``float32`` value as
    ``extract`` prints it (its shortest decimal), read as a Python float, as
    ``json.loads`` reads it: ``numpy.float32(value)`` is the pipeline's
    value exactly.

    ``params=None``: the parameters ``extract`` takes for the file (a log's
    σ and max_range from its data, ``Params.for_log``); a ``Params`` is used
    as it is. The iterator's ``params`` tells which. ``unit`` as for
    ``read_log``. The pipeline runs in a thread of its own, a few frames
    ahead, without the GIL.
    """
