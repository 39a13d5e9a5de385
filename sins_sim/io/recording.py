"""Strict reader and writer of recordings, format ``sins-sim-recording/1``.

The format is specified here and in docs/conventions.md. A
recording is an ``.npz`` archive holding

- ``meta``: a 0-d unicode array with one JSON object (the header);
- ``counts``: int64 ``(N, A)``, the accumulated readout in counts of
  ``meta.quantum_rad``, sample ``n`` at ``t = n / fs_hz``;
- ``drive_v``: float64 or float32 ``(M, A)``, the piezo voltage, held
  between updates at ``drive_fs_hz``, ``M = N * drive_fs_hz / fs_hz``;
- ``sins_angle`` (optional): float64 ``(K, A)``, the block's angle about
  each gyro axis at ``sins_fs_hz``.

The reader never guesses: a file that breaks any rule is rejected with one
:class:`RecordingError` (a ``ValueError``) whose message names the key and
the rule, e.g. ``recording x.npz: meta.fs_hz: must be a number > 0, got -1``.
Unknown header keys and unknown arrays are allowed and preserved (a
writer writes them back unchanged).

Rules the spec implies and this reader states explicitly:

- ``N >= 4`` (:data:`MIN_SAMPLES`): the readout is interpolated by cubic
  splines, like ``sins_angle``, and eq. 5 needs a second difference; fewer
  samples carry no dynamics (a 2-sample file used to pass the reader and fail
  later inside a fit);
- every array's ``.npy`` header is checked against the archive before
  anything is allocated: the shape it claims must fit in the bytes the
  archive member holds (a header claiming 2^40 rows is refused, not
  allocated); members are stored or deflated, as ``numpy.savez`` and
  ``numpy.savez_compressed`` write them;
- ``meta`` is JSON nested at most :data:`MAX_META_DEPTH` levels deep;
- ``sins_angle`` has at least 4 samples (it is interpolated by a cubic
  spline) and covers the time span of ``counts``:
  ``(K - 1) / sins_fs_hz >= (N - 1) / fs_hz``;
- ``sins_angle`` is physical: it starts within one turn and sample ``k``
  lies within 10 deg (the largest swing of a block on its isolators) plus
  1000 deg/s (the largest rate an RLG measures) times ``t_k`` of the
  first sample;
- ``meta.nominal`` has exactly one entry per axis of ``meta.axes``; each
  entry holds ``f0_hz, k1, k2, k3, k4, k5`` as finite numbers with
  ``f0_hz > 0``, ``k1 >= 0``, ``k2 > 0``, ``k3 >= 0``, ``k5 != 0``
  (docs/theory/suspension.md); other keys in an entry are preserved;
- ``meta.description``, when present, is a string (it is optional);
- ``|drive_v| <= 1000`` V (:data:`DRIVE_V_MAX`): what a piezo stack takes;
- ``meta.site`` (optional): where the bench stands and how the unit sits on it,
  ``{"latitude_deg": 56.8, "orientation_ned": {"heading_deg": 304.0, "pitch_deg": -0.7, "roll_deg": 1.1}}``
  with ``latitude_deg`` in [-90, 90], ``heading_deg`` in [-360, 360], ``pitch_deg`` in [-90, 90] and
  ``roll_deg`` in [-180, 180]: the gyro triad's x, y, z axes against local north-east-down (sequence 3-2-1)
  with the table at its zero angle; for a rate table, ``"table_axis_ned": [n, e, d]`` (a unit vector, norm
  within 1e-6 of 1) may stand beside them. With ``site`` every name of ``meta.axes`` is one of ``x, y, z``
  (the triad's axis it reads). Without ``site`` the Earth's rate is unknown to the reader but still in the
  data: on a still bench the readout carries the Earth's rate, 15.04 deg/h in magnitude, projected on each
  gyro axis by the latitude and the unit's orientation (on a table, through the table's angle).

CSV import (:func:`read_csv_recording`)
---------------------------------------
A lab export with one header line and one row per sample, comma separated,
``#`` comment lines allowed. Columns (any order, nothing else):

``time_s``
    sample time (s), ``n / fs`` for row ``n`` (uniform, starting at 0;
    deviations up to 1 % of a sample period are tolerated as rounding).
``counts_<axis>``
    accumulated readout of ``<axis>`` in counts (integer values); the
    order of these columns gives ``meta.axes``.
``drive_v_<axis>``
    piezo voltage of ``<axis>`` (V), one per counts column; the CSV
    carries one rate, so ``drive_fs_hz = fs_hz``.
``sins_angle_rad_<axis>`` (optional, for all axes or none)
    block angle about ``<axis>`` (rad); ``sins_fs_hz = fs_hz``.

The header (quantum, nominal parameters, experiment, ...) comes from the
caller's arguments.
"""

from __future__ import annotations

import copy
import csv
import io
import json
import math
import os
import re
import tempfile
import zipfile
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sins_sim.units import DEG, PIEZO_V_MAX

__all__ = ["FORMAT", "NOMINAL_KEYS", "REQUIRED_META", "SITE_AXES", "CSV_COLUMNS", "MIN_SAMPLES", "MAX_META_DEPTH",
           "DRIVE_V_MAX", "RecordingError", "Recording", "check_recording", "read_recording", "write_recording",
           "read_csv_recording"]

#: The format tag a recording's header must carry.
FORMAT = "sins-sim-recording/1"
#: Model parameters every ``meta.nominal`` entry must hold (docs/theory/suspension.md).
NOMINAL_KEYS = ("f0_hz", "k1", "k2", "k3", "k4", "k5")
#: Range of the recording's sample rates (Hz): counter, drive and table.
FS_MIN_HZ = 100.0
FS_MAX_HZ = 1.0e6
#: Range of the readout quantum (rad): 1e-9 rad up to a few fringes.
QUANTUM_MIN_RAD = 1.0e-9
QUANTUM_MAX_RAD = 1.0e-4
#: Largest |drive_v| (V): piezo stacks are rated to 100-200 V (low-voltage stacks) and up to about 1000 V (high-voltage
#: stacks); the same bound as the drive model's (:data:`sins_sim.models.drive.V_MAX`; both from sins_sim.units). A
#: larger value is not a voltage (DAC codes, a unit slip, a corrupted column) and would overflow the fits.
DRIVE_V_MAX = PIEZO_V_MAX  # the drive model's limit too (sins_sim.units)
#: Largest block rate (rad/s) a recording's ``sins_angle`` may show: the input range of navigation-grade RLGs is
#: +-400 to +-1000 deg/s (the scenario's block-rate bound, sins_sim.config.scenario.MAX_RATE_DEG_S, is the same).
SINS_RATE_MAX_RAD_S = 1000.0 * DEG
#: Largest angle (rad) the block may sit away from its start beyond what that rate turns it by: a block on its
#: isolators swings by arcminutes (the dither itself is arcminutes); 10 deg is the scenario's bound on an angular
#: vibration amplitude (sins_sim.config.scenario.MAX_ANGLE_ARCMIN = 600 arcmin), where the isolators would tear.
SINS_SWING_MAX_RAD = 10.0 * DEG
#: Largest |angle| (rad) of the first ``sins_angle`` sample: an orientation about an axis lies within one turn.
SINS_START_MAX_RAD = 2.0 * math.pi
#: Header keys that must be present (``sins_fs_hz`` only with ``sins_angle``).
REQUIRED_META = ("format", "axes", "fs_hz", "drive_fs_hz", "quantum_rad", "initial_state", "experiment", "nominal")
INITIAL_STATES = ("rest", "unknown")
#: Arrays of the format; any other array in the archive is kept as an extra.
ARRAYS = ("meta", "counts", "drive_v", "sins_angle")
#: CSV columns understood by :func:`read_csv_recording` (``<axis>`` is the axis name).
CSV_COLUMNS = ("time_s", "counts_<axis>", "drive_v_<axis>", "sins_angle_rad_<axis>")
#: Fewest samples ``counts`` may hold (cubic interpolation, as for ``sins_angle``).
MIN_SAMPLES = 4
#: The gyro triad's axes a ``site`` orients (the names ``meta.axes`` may use with ``site``).
SITE_AXES = ("x", "y", "z")
#: Tolerance on the norm of ``site.table_axis_ned`` (a unit vector written with finite decimals).
SITE_UNIT_TOL = 1.0e-6
#: Deepest nesting of objects and lists allowed in ``meta`` (a header is a few levels deep).
MAX_META_DEPTH = 32
#: Most a deflate stream can expand (about 1032:1), plus slack: a member claiming more is corrupt.
_DEFLATE_MAX_RATIO = 1100


class RecordingError(ValueError):
    """A recording broke a rule of ``sins-sim-recording/1``; the message names the key and the rule."""


def _fail(where: str, key: str, rule: str):
    raise RecordingError(f"{where}: {key}: {rule}")


def _is_number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _number(where, key, value, rule="must be a finite number", check=None):
    if not _is_number(value) or not math.isfinite(float(value)):
        _fail(where, key, f"{rule}, got {value!r}")
    value = float(value)
    if check is not None and not check(value):
        _fail(where, key, f"{rule}, got {value!r}")
    return value


_NOMINAL_RULES = {
    "f0_hz": ("must be a finite number > 0", lambda x: x > 0.0),
    "k1": ("must be a finite number >= 0", lambda x: x >= 0.0),
    "k2": ("must be a finite number > 0", lambda x: x > 0.0),
    "k3": ("must be a finite number >= 0", lambda x: x >= 0.0),
    "k4": ("must be a finite number", None),
    "k5": ("must be a finite number != 0", lambda x: x != 0.0),
}


def _check_meta(meta, where: str) -> None:
    if not isinstance(meta, dict):
        _fail(where, "meta", f"must hold a JSON object, got {type(meta).__name__}")
    for key in REQUIRED_META:
        if key not in meta:
            _fail(where, f"meta.{key}", "is required but missing")
    if meta["format"] != FORMAT:
        _fail(where, "meta.format", f"must be {FORMAT!r}, got {meta['format']!r}")
    axes = meta["axes"]
    if not isinstance(axes, list) or not 1 <= len(axes) <= 3:
        _fail(where, "meta.axes", f"must be a list of 1 to 3 axis names, got {axes!r}")
    for i, a in enumerate(axes):
        if not isinstance(a, str) or not a:
            _fail(where, f"meta.axes[{i}]", f"must be a non-empty string, got {a!r}")
    if len(set(axes)) != len(axes):
        _fail(where, "meta.axes", f"axis names must be distinct, got {axes!r}")
    # a fringe counter read at 100 Hz .. 1 MHz (the paper's readout runs at 7.2 kHz; below 100 Hz a dither of
    # 100-1500 Hz cannot be seen at all, above 1 MHz no counter interface exists): a rate in kHz or 1e30 is an error
    rate_rule = f"must be a number in [{FS_MIN_HZ:g}, {FS_MAX_HZ:g}] Hz"
    in_range = lambda x: FS_MIN_HZ <= x <= FS_MAX_HZ  # noqa: E731
    fs = _number(where, "meta.fs_hz", meta["fs_hz"], rate_rule, in_range)
    dfs = _number(where, "meta.drive_fs_hz", meta["drive_fs_hz"], rate_rule, in_range)
    ratio = dfs / fs
    if round(ratio) < 1 or abs(ratio - round(ratio)) > 1e-9 * max(1.0, ratio):
        _fail(where, "meta.drive_fs_hz", f"drive_fs_hz / fs_hz must be an integer >= 1, got {ratio!r}")
    if "sins_fs_hz" in meta:
        _number(where, "meta.sins_fs_hz", meta["sins_fs_hz"], rate_rule, in_range)
    # a fringe counter's angle per count: a fraction of a 2.42 arcsec fringe (1.17e-5 rad; the paper's readout
    # interpolates to 1/16 of it); a quantum given in arcsec (0.15) or in degrees would be a misread file
    _number(where, "meta.quantum_rad", meta["quantum_rad"], f"must be a number in [{QUANTUM_MIN_RAD:g}, "
            f"{QUANTUM_MAX_RAD:g}] rad (an RLG fringe is 1.17e-5 rad)", lambda x: QUANTUM_MIN_RAD <= x <= QUANTUM_MAX_RAD)
    if meta["initial_state"] not in INITIAL_STATES:
        _fail(where, "meta.initial_state", f"must be one of {list(INITIAL_STATES)}, got {meta['initial_state']!r}")
    if not isinstance(meta["experiment"], str):
        _fail(where, "meta.experiment", f"must be a string, got {meta['experiment']!r}")
    if "description" in meta and not isinstance(meta["description"], str):
        _fail(where, "meta.description", f"must be a string, got {meta['description']!r}")
    nominal = meta["nominal"]
    if not isinstance(nominal, dict):
        _fail(where, "meta.nominal", f"must be an object with one entry per axis, got {nominal!r}")
    for a in axes:
        if a not in nominal:
            _fail(where, f"meta.nominal.{a}", "is required (one entry per axis of meta.axes) but missing")
    for a in nominal:
        if a not in axes:
            _fail(where, f"meta.nominal.{a}", f"is not an axis of meta.axes {axes!r}")
        entry = nominal[a]
        if not isinstance(entry, dict):
            _fail(where, f"meta.nominal.{a}", f"must be an object with {list(NOMINAL_KEYS)}, got {entry!r}")
        for k in NOMINAL_KEYS:
            if k not in entry:
                _fail(where, f"meta.nominal.{a}.{k}", "is required but missing")
            rule, check = _NOMINAL_RULES[k]
            _number(where, f"meta.nominal.{a}.{k}", entry[k], rule, check)
    if "site" in meta:
        _check_site(meta["site"], axes, where)


_SITE_ANGLES = {"heading_deg": 360.0, "pitch_deg": 90.0, "roll_deg": 180.0}


def _check_site(site, axes, where: str) -> None:
    """``meta.site``: latitude, orientation against NED (3-2-1) and, optionally, a rate table's axis."""
    if not isinstance(site, dict):
        _fail(where, "meta.site", f"must be an object with latitude_deg and orientation_ned, got {site!r}")
    for key in ("latitude_deg", "orientation_ned"):
        if key not in site:
            _fail(where, f"meta.site.{key}", "is required but missing")
    _number(where, "meta.site.latitude_deg", site["latitude_deg"], "must be a number in [-90, 90] deg",
            lambda x: -90.0 <= x <= 90.0)
    ori = site["orientation_ned"]
    if not isinstance(ori, dict):
        _fail(where, "meta.site.orientation_ned", f"must be an object with {list(_SITE_ANGLES)}, got {ori!r}")
    for key, lim in _SITE_ANGLES.items():
        if key not in ori:
            _fail(where, f"meta.site.orientation_ned.{key}", "is required but missing")
        _number(where, f"meta.site.orientation_ned.{key}", ori[key], f"must be a number in [-{lim:g}, {lim:g}] deg",
                lambda x, lim=lim: -lim <= x <= lim)
    if "table_axis_ned" in site:
        ax = site["table_axis_ned"]
        if (not isinstance(ax, list) or len(ax) != 3 or not all(_is_number(c) and math.isfinite(float(c)) for c in ax)
                or abs(math.sqrt(sum(float(c) ** 2 for c in ax)) - 1.0) > SITE_UNIT_TOL):
            _fail(where, "meta.site.table_axis_ned", f"must be a unit vector [n, e, d] of 3 finite numbers (norm 1 "
                                                     f"within {SITE_UNIT_TOL:g}), got {ax!r}")
    for a in axes:
        if a not in SITE_AXES:
            _fail(where, "meta.axes", f"must name axes of the triad {list(SITE_AXES)} when meta.site orients it, "
                                      f"got {a!r}")


def check_recording(meta, counts, drive_v, sins_angle=None, where: str = "recording") -> None:
    """Check a header and its arrays against every rule of ``sins-sim-recording/1``.

    Parameters
    ----------
    meta : dict
        The header (parsed JSON).
    counts, drive_v, sins_angle : ndarray
        The arrays; ``sins_angle`` may be ``None`` (block at rest).
    where : str
        Prefix of the error message (the file name).

    Raises
    ------
    RecordingError
        Naming the key and the rule.
    """
    _check_meta(meta, where)
    n_axes = len(meta["axes"])
    if not isinstance(counts, np.ndarray) or counts.dtype != np.int64:
        _fail(where, "counts", f"must be an int64 array, got {getattr(counts, 'dtype', type(counts).__name__)}")
    if counts.ndim != 2 or counts.shape[1] != n_axes:
        _fail(where, "counts", f"must have shape (N, A) with A = len(meta.axes) = {n_axes}, got {counts.shape}")
    n = counts.shape[0]
    if n < MIN_SAMPLES:
        _fail(where, "counts", f"must hold at least {MIN_SAMPLES} samples (N >= {MIN_SAMPLES}), got {n}")
    if not isinstance(drive_v, np.ndarray) or drive_v.dtype not in (np.float64, np.float32):
        _fail(where, "drive_v", f"must be a float64 or float32 array, got "
                                f"{getattr(drive_v, 'dtype', type(drive_v).__name__)}")
    ratio = int(round(float(meta["drive_fs_hz"]) / float(meta["fs_hz"])))
    if drive_v.ndim != 2 or drive_v.shape != (n * ratio, n_axes):
        _fail(where, "drive_v", f"must have shape (M, A) = ({n * ratio}, {n_axes}) with M = N * drive_fs_hz / fs_hz, "
                                f"got {drive_v.shape}")
    if not np.all(np.isfinite(drive_v)):
        bad = np.argwhere(~np.isfinite(drive_v))[0]
        _fail(where, "drive_v", f"must be finite everywhere, NaN/inf at {tuple(int(i) for i in bad)}")
    if drive_v.size and float(np.max(np.abs(drive_v))) > DRIVE_V_MAX:
        bad = np.unravel_index(int(np.argmax(np.abs(drive_v))), drive_v.shape)
        _fail(where, "drive_v", f"must lie in [-{DRIVE_V_MAX:g}, {DRIVE_V_MAX:g}] V (a piezo stack takes at most "
                                f"about {DRIVE_V_MAX:g} V; DAC codes or another unit are not volts), got "
                                f"{float(drive_v[bad]):.4g} at {tuple(int(i) for i in bad)}")
    if sins_angle is None:
        return
    if "sins_fs_hz" not in meta:
        _fail(where, "meta.sins_fs_hz", "is required when sins_angle is present but missing")
    if not isinstance(sins_angle, np.ndarray) or sins_angle.dtype != np.float64:
        _fail(where, "sins_angle", f"must be a float64 array, got "
                                   f"{getattr(sins_angle, 'dtype', type(sins_angle).__name__)}")
    if sins_angle.ndim != 2 or sins_angle.shape[1] != n_axes:
        _fail(where, "sins_angle", f"must have shape (K, A) with A = {n_axes}, got {sins_angle.shape}")
    k = sins_angle.shape[0]
    if k < 4:
        _fail(where, "sins_angle", f"must hold at least 4 samples (cubic interpolation), got {k}")
    if not np.all(np.isfinite(sins_angle)):
        bad = np.argwhere(~np.isfinite(sins_angle))[0]
        _fail(where, "sins_angle", f"must be finite everywhere, NaN/inf at {tuple(int(i) for i in bad)}")
    _check_angle_physical(sins_angle, float(meta["sins_fs_hz"]), meta["axes"], where)
    span_counts = (n - 1) / float(meta["fs_hz"])
    span_angle = (k - 1) / float(meta["sins_fs_hz"])
    if span_angle < span_counts * (1.0 - 1e-12):
        _fail(where, "sins_angle", f"must cover the time span of counts, (N - 1) / fs_hz = {span_counts!r} s, "
                                   f"got (K - 1) / sins_fs_hz = {span_angle!r} s")


def _check_angle_physical(sins_angle: np.ndarray, sins_fs_hz: float, axes: list, where: str) -> None:
    """Refuse a block angle no block on its isolators can turn through.

    Sample ``k`` (at ``t_k = k / sins_fs_hz``) must satisfy ``|theta_0| <= 2 pi`` (a start within one turn) and
    ``|theta_k - theta_0| <= SINS_SWING_MAX_RAD + SINS_RATE_MAX_RAD_S * t_k``: the table's turn at the largest
    rate an RLG measures plus the largest swing of the block on its isolators. A column scaled by a unit slip
    (arcsec or microradians read as rad) or a corrupted one (1e300) breaks it, and would overflow the fits.
    """
    start = np.abs(sins_angle[0])
    if float(np.max(start)) > SINS_START_MAX_RAD:
        a = int(np.argmax(start))
        _fail(where, "sins_angle", f"must start within one turn, |angle| <= 2 pi rad, got {float(sins_angle[0, a]):.4g} "
                                   f"rad on axis {axes[a]} (the block's angle in rad; another unit or a corrupted column?)")
    t = np.arange(sins_angle.shape[0])[:, None] / sins_fs_hz
    with np.errstate(over="ignore", invalid="ignore"):  # +-1e308 apart overflows to inf: refused all the same
        excess = np.abs(sins_angle - sins_angle[0]) - (SINS_SWING_MAX_RAD + SINS_RATE_MAX_RAD_S * t)
    if float(np.max(excess)) > 0.0:
        i, a = np.unravel_index(int(np.argmax(excess)), excess.shape)
        _fail(where, "sins_angle", f"must stay within the physical range |angle - angle[0]| <= 10 deg + 1000 deg/s * t "
                                   f"(an isolated block swings by arcminutes, an RLG measures at most 1000 deg/s), got "
                                   f"{float(sins_angle[i, a] - sins_angle[0, a]):.4g} rad at sample {int(i)} "
                                   f"(t = {float(t[i, 0]):.4g} s) on axis {axes[int(a)]}")


@dataclass(frozen=True)
class Recording:
    """A validated recording (arrays read-only, header deep-copied).

    Parameters
    ----------
    meta : dict
        The header, unknown keys included.
    counts : ndarray of int64, shape (N, A)
    drive_v : ndarray of float64 or float32, shape (M, A)
    sins_angle : ndarray of float64, shape (K, A), or None
    extra : dict of ndarray
        Arrays of the archive that the format does not define (preserved).

    Examples
    --------
    >>> import numpy as np
    >>> meta = {"format": FORMAT, "axes": ["x"], "fs_hz": 7200.0, "drive_fs_hz": 7200.0,
    ...         "quantum_rad": 1e-6, "initial_state": "rest", "experiment": "stationary",
    ...         "nominal": {"x": {"f0_hz": 386.0, "k1": 1.75e-4, "k2": 1.05e-3, "k3": 4.4e-3,
    ...                           "k4": 250.0, "k5": -1.2e-5}}}
    >>> rec = Recording(meta, np.zeros((4, 1), np.int64), np.zeros((4, 1)))
    >>> rec.axes, rec.n_samples, rec.duration_s
    (('x',), 4, 0.0004166666666666667)
    """

    meta: dict
    counts: np.ndarray
    drive_v: np.ndarray
    sins_angle: np.ndarray | None = None
    extra: dict = field(default_factory=dict)
    source: str = "recording"

    def __post_init__(self):
        check_recording(self.meta, self.counts, self.drive_v, self.sins_angle, where=self.source)
        object.__setattr__(self, "meta", copy.deepcopy(self.meta))
        for name in ("counts", "drive_v", "sins_angle"):
            arr = getattr(self, name)
            if arr is not None:
                arr = np.array(arr, order="C")
                arr.setflags(write=False)
                object.__setattr__(self, name, arr)
        extra = {}
        for k, arr in self.extra.items():
            if k in ARRAYS:
                raise RecordingError(f"{self.source}: extra.{k}: is an array of the format, not an extra")
            arr = np.array(arr)
            arr.setflags(write=False)
            extra[k] = arr
        object.__setattr__(self, "extra", extra)

    # --- header -----------------------------------------------------------------------------
    @property
    def axes(self) -> tuple:
        return tuple(self.meta["axes"])

    @property
    def n_axes(self) -> int:
        return len(self.meta["axes"])

    @property
    def fs_hz(self) -> float:
        return float(self.meta["fs_hz"])

    @property
    def drive_fs_hz(self) -> float:
        return float(self.meta["drive_fs_hz"])

    @property
    def drive_ratio(self) -> int:
        """``drive_fs_hz / fs_hz`` (an integer >= 1)."""
        return int(round(self.drive_fs_hz / self.fs_hz))

    @property
    def sins_fs_hz(self) -> float | None:
        return float(self.meta["sins_fs_hz"]) if "sins_fs_hz" in self.meta else None

    @property
    def quantum_rad(self) -> float:
        return float(self.meta["quantum_rad"])

    @property
    def initial_state(self) -> str:
        return self.meta["initial_state"]

    @property
    def experiment(self) -> str:
        return self.meta["experiment"]

    @property
    def site(self) -> dict | None:
        """A copy of ``meta.site`` (latitude, orientation, table axis), or None when the header has none."""
        return copy.deepcopy(self.meta["site"]) if "site" in self.meta else None

    @property
    def nominal(self) -> dict:
        """Per axis, a copy of the nominal entry (``f0_hz, k1..k5`` as floats, other keys as stored)."""
        out = {}
        for a in self.axes:
            entry = dict(self.meta["nominal"][a])
            for k in NOMINAL_KEYS:
                entry[k] = float(entry[k])
            out[a] = entry
        return out

    @property
    def n_samples(self) -> int:
        return int(self.counts.shape[0])

    @property
    def duration_s(self) -> float:
        """Time of the last sample, ``(N - 1) / fs_hz`` (s)."""
        return (self.n_samples - 1) / self.fs_hz

    # --- data -------------------------------------------------------------------------------
    def time(self) -> np.ndarray:
        """Sample times ``n / fs_hz`` (s)."""
        return np.arange(self.n_samples) / self.fs_hz

    def axis_index(self, axis: str) -> int:
        if axis not in self.axes:
            raise ValueError(f"recording: axis: must be one of {list(self.axes)}, got {axis!r}")
        return self.axes.index(axis)

    def angle(self, axis: str | None = None) -> np.ndarray:
        """Readout angle ``counts * quantum_rad`` (rad), all axes ``(N, A)`` or one ``(N,)``."""
        c = self.counts if axis is None else self.counts[:, self.axis_index(axis)]
        return c.astype(np.float64) * self.quantum_rad

    def select(self, axes) -> "Recording":
        """The same recording restricted to some axes (in the given order)."""
        idx = [self.axis_index(a) for a in axes]
        meta = copy.deepcopy(self.meta)
        meta["axes"] = list(axes)
        meta["nominal"] = {a: meta["nominal"][a] for a in axes}
        return Recording(meta, self.counts[:, idx], self.drive_v[:, idx],
                         None if self.sins_angle is None else self.sins_angle[:, idx], dict(self.extra), self.source)


def _load_meta(arr, where):
    if not isinstance(arr, np.ndarray) or arr.ndim != 0 or arr.dtype.kind != "U":
        _fail(where, "meta", f"must be a 0-d unicode array holding one JSON object, got "
                             f"{getattr(arr, 'dtype', type(arr).__name__)} of shape {getattr(arr, 'shape', None)}")

    def reject(const):
        raise ValueError(f"{const} is not valid JSON")

    text = str(arr[()])
    depth = _json_depth(text, MAX_META_DEPTH)
    if depth > MAX_META_DEPTH:
        _fail(where, "meta", f"must hold JSON nested at most {MAX_META_DEPTH} levels deep, got more")
    def unique(pairs):
        seen = {}
        for k, val in pairs:
            if k in seen:
                raise ValueError(f"duplicate key {k!r}")
            seen[k] = val
        return seen

    try:
        meta = json.loads(text, parse_constant=reject, object_pairs_hook=unique)
    except ValueError as exc:
        _fail(where, "meta", f"must hold valid JSON without duplicate keys ({exc})")
    if not isinstance(meta, dict):
        _fail(where, "meta", f"must hold a JSON object, got {type(meta).__name__}")
    return meta


_JSON_TOKENS = re.compile(r'"(?:[^"\\]|\\.)*"|[\[\]{}]')


def _json_depth(text: str, limit: int) -> int:
    """Nesting depth of the objects and lists in JSON ``text`` (strings skipped), counted up to ``limit + 1``."""
    depth = deepest = 0
    for m in _JSON_TOKENS.finditer(text):
        tok = m.group()
        if tok in "[{":
            depth += 1
            if depth > deepest:
                deepest = depth
                if deepest > limit:
                    break
        elif tok in "]}":
            depth -= 1
    return deepest


def _npy_header(fp):
    """(shape, dtype, header length in bytes) of an ``.npy`` stream positioned at its start."""
    fmt = np.lib.format
    version = fmt.read_magic(fp)
    if version == (1, 0):
        shape, _, dtype = fmt.read_array_header_1_0(fp)
    elif version == (2, 0):
        shape, _, dtype = fmt.read_array_header_2_0(fp)
    else:
        raise ValueError(f".npy format version {version[0]}.{version[1]} is not supported (1.0 or 2.0)")
    return shape, dtype, fp.tell()


def _check_members(path: Path, where: str) -> None:
    """Check every archive member's ``.npy`` header against the bytes the member holds, before loading.

    A header may claim any shape; numpy would allocate it before reading. The
    claimed array must fit in the member's declared size, and that size in
    what its compressed bytes can expand to.
    """
    try:
        zf = zipfile.ZipFile(path)
    except (OSError, zipfile.BadZipFile, ValueError, EOFError) as exc:
        _fail(where, "file", f"must be a NumPy .npz archive ({exc})")
    with zf:
        seen = set()
        for info in zf.infolist():
            if info.filename in seen:
                # numpy.load would read one of the two copies (zipfile keeps the last): which array the
                # recording holds would be an accident of the archive's layout
                _fail(where, info.filename[:-4] if info.filename.endswith(".npy") else info.filename,
                      "archive member stored twice: a recording holds each array once")
            seen.add(info.filename)
            if not info.filename.endswith(".npy"):
                continue
            key = info.filename[:-4]
            if info.compress_type == zipfile.ZIP_STORED:
                if info.file_size != info.compress_size:
                    _fail(where, key, f"archive member claims {info.file_size} bytes but stores "
                                      f"{info.compress_size}")
            elif info.compress_type == zipfile.ZIP_DEFLATED:
                if info.file_size > _DEFLATE_MAX_RATIO * info.compress_size + 2 ** 16:
                    _fail(where, key, f"archive member claims {info.file_size} bytes from {info.compress_size} "
                                      "compressed bytes, more than deflate can produce")
            else:
                _fail(where, key, "archive member must be stored or deflated (as numpy.savez or "
                                  f"numpy.savez_compressed write it), got compression method {info.compress_type}")
            try:
                with zf.open(info) as fp:
                    shape, dtype, header_len = _npy_header(fp)
            except (OSError, ValueError, zipfile.BadZipFile, EOFError, zlib.error) as exc:
                _fail(where, key, f"must be a readable .npy array ({' '.join(str(exc).split())})")
            if dtype.hasobject:
                continue  # refused when loaded: a recording may not use pickle
            count = math.prod(int(d) for d in shape)
            need = count * dtype.itemsize
            have = info.file_size - header_len
            if need > have:
                _fail(where, key, f"the .npy header claims shape {tuple(shape)} of {dtype} ({need} bytes), but the "
                                  f"archive member holds {max(have, 0)} bytes of data: an array's shape must fit "
                                  "in the file")


def read_recording(path) -> Recording:
    """Read and check a recording file (``.npz``, compressed or not).

    Raises
    ------
    RecordingError
        When the file is not an ``.npz`` archive or breaks any rule of the
        format; the message names the file, the key and the rule.
    """
    path = Path(path)
    where = f"recording {path}"
    if not path.is_file():
        _fail(where, "file", "does not exist or is not a file")
    try:
        archive = np.load(path, allow_pickle=False)
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
        _fail(where, "file", f"must be a NumPy .npz archive ({exc})")
    if not isinstance(archive, np.lib.npyio.NpzFile):
        _fail(where, "file", "must be a NumPy .npz archive, got a single .npy array")
    with archive:
        _check_members(path, where)
        names = list(archive.files)
        for key in ("meta", "counts", "drive_v"):
            if key not in names:
                _fail(where, key, "is a required array but missing")
        arrays = {}
        for key in names:
            try:
                arrays[key] = archive[key]
            except ValueError as exc:  # object arrays need pickle, which a recording may not use
                _fail(where, key, f"must be a plain (non-object) array ({exc})")
            except (OSError, zipfile.BadZipFile, EOFError, zlib.error) as exc:
                _fail(where, key, f"cannot be read (corrupted data: {' '.join(str(exc).split())})")
            except MemoryError:
                _fail(where, key, "is too large to load into memory")
    meta = _load_meta(arrays["meta"], where)
    extra = {k: v for k, v in arrays.items() if k not in ARRAYS}
    return Recording(meta, arrays["counts"], arrays["drive_v"], arrays.get("sins_angle"), extra, where)


def write_recording(path, recording: Recording, compressed: bool = True) -> Path:
    """Write a recording to ``path`` exactly (no suffix is added); return the path.

    The header is written as compact JSON (``NaN`` and infinities are
    refused); extras are written back unchanged.
    """
    if not isinstance(recording, Recording):
        raise ValueError(f"recording: must be a Recording, got {type(recording).__name__}")
    path = Path(path)
    arrays = {"meta": np.array(json.dumps(recording.meta, allow_nan=False, sort_keys=False)),
              "counts": recording.counts, "drive_v": recording.drive_v}
    if recording.sins_angle is not None:
        arrays["sins_angle"] = recording.sins_angle
    arrays.update(recording.extra)
    buf = io.BytesIO()
    (np.savez_compressed if compressed else np.savez)(buf, **arrays)
    path.parent.mkdir(parents=True, exist_ok=True)
    # in one step: a reader sees the old file or the new one, never a part
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.tmp-", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(buf.getvalue())
        mask = os.umask(0)
        os.umask(mask)
        os.chmod(tmp, 0o666 & ~mask)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
    return path


def _csv_fail(where, key, rule):
    raise RecordingError(f"{where}: {key}: {rule}")


def read_csv_recording(csv_path, quantum_rad: float, nominal: dict, experiment: str = "stationary",
                       initial_state: str = "rest", description: str = "", fs_hz: float | None = None,
                       **extra_meta) -> Recording:
    """Build a recording from a lab CSV export (columns in the module docstring).

    Parameters
    ----------
    csv_path : path
        The CSV file.
    quantum_rad : float
        Angle per count (rad).
    nominal : dict
        Per axis, ``{"f0_hz":, "k1":, ..., "k5":}`` (and any other keys).
    experiment, initial_state, description : str
        Header fields.
    fs_hz : float, optional
        Sample rate; default ``1 / mean spacing`` of ``time_s``.
    **extra_meta
        Further header keys, stored as given.

    Raises
    ------
    RecordingError
        Naming the column (or header key) and the rule.
    """
    path = Path(csv_path)
    where = f"csv {path}"
    try:
        text = path.read_text()
    except OSError as exc:
        _csv_fail(where, "file", f"cannot be read ({exc.strerror})")
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if len(lines) < 3:
        _csv_fail(where, "file", f"must hold a header line and at least 2 rows, got {len(lines)} line(s)")
    rows = list(csv.reader(lines))
    header = [h.strip() for h in rows[0]]
    if len(set(header)) != len(header):
        _csv_fail(where, "header", f"column names must be distinct, got {header}")
    if "time_s" not in header:
        _csv_fail(where, "time_s", "column is required but missing")
    axes, drive_cols, angle_cols = [], {}, {}
    for h in header:
        if h == "time_s":
            continue
        if h.startswith("counts_") and len(h) > 7:
            axes.append(h[7:])
        elif h.startswith("drive_v_") and len(h) > 8:
            drive_cols[h[8:]] = h
        elif h.startswith("sins_angle_rad_") and len(h) > 15:
            angle_cols[h[15:]] = h
        else:
            _csv_fail(where, h, f"unknown column (allowed: {', '.join(CSV_COLUMNS)})")
    if not 1 <= len(axes) <= 3:
        _csv_fail(where, "counts_<axis>", f"must be given for 1 to 3 axes, got {len(axes)}")
    for a in axes:
        if a not in drive_cols:
            _csv_fail(where, f"drive_v_{a}", "column is required for every counts column but missing")
    for a in list(drive_cols) + list(angle_cols):
        if a not in axes:
            col = drive_cols.get(a) or angle_cols.get(a)
            _csv_fail(where, col, f"has no counts_{a} column")
    if angle_cols and set(angle_cols) != set(axes):
        missing = [a for a in axes if a not in angle_cols]
        _csv_fail(where, f"sins_angle_rad_{missing[0]}", "must be given for all axes or for none")
    width = len(header)
    data = np.empty((len(rows) - 1, width))
    for i, row in enumerate(rows[1:]):
        if len(row) != width:
            _csv_fail(where, f"row {i + 1}", f"must have {width} fields, got {len(row)}")
        for j, cell in enumerate(row):
            try:
                data[i, j] = float(cell)
            except ValueError:
                _csv_fail(where, f"{header[j]} row {i + 1}", f"must be a number, got {cell!r}")
    if not np.all(np.isfinite(data)):
        i, j = np.argwhere(~np.isfinite(data))[0]
        _csv_fail(where, f"{header[j]} row {i + 1}", "must be finite")
    col = {h: data[:, j] for j, h in enumerate(header)}
    t = col["time_s"]
    n = t.size
    if fs_hz is None:
        if not t[-1] > t[0]:
            _csv_fail(where, "time_s", "must increase")
        fs_hz = (n - 1) / (t[-1] - t[0])
    fs_hz = float(fs_hz)
    if not (math.isfinite(fs_hz) and fs_hz > 0.0):
        _csv_fail(where, "fs_hz", f"must be a number > 0, got {fs_hz!r}")
    dev = np.abs(t - np.arange(n) / fs_hz) * fs_hz
    if dev.max() > 0.01:
        i = int(np.argmax(dev))
        _csv_fail(where, "time_s", f"must be n / fs_hz (uniform from 0, fs_hz = {fs_hz:.9g}); row {i + 1} is "
                                   f"off by {dev[i]:.3g} sample periods")
    counts = np.empty((n, len(axes)), dtype=np.int64)
    for i, a in enumerate(axes):
        c = col[f"counts_{a}"]
        if np.any(c != np.round(c)) or np.any(np.abs(c) > 2.0 ** 62):
            r = int(np.flatnonzero((c != np.round(c)) | (np.abs(c) > 2.0 ** 62))[0])
            _csv_fail(where, f"counts_{a} row {r + 1}", f"must be an integer, got {c[r]!r}")
        counts[:, i] = c.astype(np.int64)
    drive = np.column_stack([col[drive_cols[a]] for a in axes]).astype(np.float64)
    meta = {"format": FORMAT, "axes": axes, "fs_hz": fs_hz, "drive_fs_hz": fs_hz, "quantum_rad": quantum_rad,
            "initial_state": initial_state, "experiment": experiment, "nominal": copy.deepcopy(nominal),
            "description": description, **extra_meta}
    sins = None
    if angle_cols:
        meta["sins_fs_hz"] = fs_hz
        sins = np.column_stack([col[angle_cols[a]] for a in axes]).astype(np.float64)
    return Recording(meta, counts, drive, sins, {}, where)
