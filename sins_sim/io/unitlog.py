"""A strapdown unit's own log: read it, check its time base, and convert it to increments in FRD axes.

A real unit logs in its own layout: integer pulse counts (or increments, or rates) per interval, its own
axis labels (right-forward-up, ...), a time column or none, header rows carrying the site. This module
reads such a file as a :class:`LogLayout` describes it (built by :mod:`sins_sim.config.log` from a YAML
description, or by hand) and returns the increments sins-sim navigates: :class:`UnitLog`, angle
increments ``dtheta`` (rad) and velocity increments ``dv`` (m/s) per interval in the vehicle's body axes
x forward, y right, z down (FRD), with the end time of each interval, and a report of what was found.

Conversion, per interval ``k`` and log channel ``i`` (weights and scales in SI):

- ``counts``: ``x_k = w_i N_k`` (``w_i``: the pulse weight, e.g. 0.1 arcsec or 125 ug s);
- ``totals`` (a running pulse counter read out at each row): ``x_k = w_i (M_k - M_{k-1})``, the difference
  wrapped for a ``b``-bit counter that rolls over; the first row is the reference (no interval of its own);
- ``increments``: ``x_k = s_i u_k`` (``s_i``: the column's unit in SI times its scale);
- ``rates``: ``x_k = s_i r_k dt``, the rectangle rule: the logged rate is taken as the interval's mean
  rate (exact for a unit that logs its increments divided by ``dt``; a rate sampled at the end of the
  interval is in error by ``r' dt^2 / 2`` per interval, Savage 2000, sec. 7.1).

Then to FRD: with ``C`` the axes matrix whose rows are the log's axes expressed in FRD (``R`` =
``(0, 1, 0)``, ``U`` = ``(0, 0, -1)``...), a vector's log components are ``v_log = C v_frd`` and so
``v_frd = C^T v_log`` (``C`` orthonormal: Titterton & Weston 2004, sec. 3.2). Gyro and accelerometer
channels are components along the same labelled axes; a channel counting against its label takes a
negative weight.

Time base: a fixed rate (no time column: interval ``k`` ends at ``start + (k + 1) dt``), or a time column
checked step by step against the period ``dt`` (the given rate, or the least-squares slope of the
times over their interval numbers):

- a step of ``0`` periods with the same data is an exact duplicate row (a logger repeating a record):
  dropped and counted; with different data it is refused naming both lines;
- a step of ``k >= 2`` periods is a gap of ``k - 1`` missing intervals: refused by default naming the
  first gap's lines and times and how many gaps; with ``gaps="fill_mean"`` each missing interval gets
  the mean of the increments of the interval before and the interval after the gap (the motion's
  curvature across the gap is lost: a filled interval is an estimate), every filled interval listed
  in the report; for running totals nothing is lost: the difference across the gap is shared evenly by
  the intervals it spans (the sum exact, its distribution over the gap an estimate);
- a step that is not within ``jitter`` periods of a whole number, a time going backwards, or a clock
  that wanders more than ``jitter`` periods from the fitted grid is refused naming the line.

The times written out are the grid ``t_0 + n dt`` (the navigator needs uniform spacing; the largest
distance of a logged time from its grid point is in the report).

Every failure is one :class:`LogFileError` line (a ``ValueError``) naming the file, the line (text) or
row (Parquet), and the column or the description's key.
"""

from __future__ import annotations

import csv
import math
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sins_sim.earth import EARTH_RATE_RAD_S

__all__ = ["LogFileError", "HeaderValue", "LogLayout", "UnitLog", "read_unit_log", "axes_matrix", "check_rotation",
           "rest_latitude", "AXIS_VECTORS", "AXIS_WORDS", "DELIMITERS", "ROTATION_TOLERANCE", "REST_WINDOW_S",
           "LATITUDE_SIN_TOLERANCE"]

#: Each body-axis letter as a unit vector in FRD (x forward, y right, z down).
AXIS_VECTORS = {"F": (1.0, 0.0, 0.0), "B": (-1.0, 0.0, 0.0), "R": (0.0, 1.0, 0.0), "L": (0.0, -1.0, 0.0),
                "D": (0.0, 0.0, 1.0), "U": (0.0, 0.0, -1.0)}
#: Long forms of the letters (lower case).
AXIS_WORDS = {"forward": "F", "fwd": "F", "front": "F", "fore": "F", "nose": "F",
              "back": "B", "backward": "B", "backwards": "B", "aft": "B", "rear": "B",
              "right": "R", "starboard": "R", "left": "L", "port": "L", "up": "U", "upward": "U", "down": "D",
              "downward": "D"}
#: Delimiters of text logs.
DELIMITERS = {"whitespace": None, "comma": ",", "semicolon": ";", "tab": "\t"}
#: Largest entry of ``|C C^T - I|`` for an axes matrix (entries written to 7 digits pass; 0.7071 for
#: cos 45 deg does not: it is 20 arcsec off, more than a navigation-grade unit's mounting error).
ROTATION_TOLERANCE = 1e-6
#: The rest check looks at the log's first seconds at rest, at most this many (s), at least 10 one-second blocks.
REST_WINDOW_S = 60.0
_REST_MIN_BLOCKS = 10
#: At rest, each one-second block's mean specific force stays within this of the first block's (m/s^2: 5 mg, far
#: above a stationary vehicle's averaged vibration, below a vehicle starting off) ...
_REST_FORCE_M_S2 = 0.05
#: ... and its mean rate within this many Earth rates of the first block's (75 deg/h: above the 1-s noise of a
#: tactical-grade gyro, ARW 0.1 deg/sqrt(h) -> 6 deg/h; below a vehicle rocking or turning).
_REST_RATE_EARTH = 5.0
#: The given latitude and the one the log implies at rest disagree when their sines differ by more than this: it
#: takes a vertical-gyro bias of 0.25 Earth rate (3.8 deg/h) to move the implied sine that far, a bias a
#: navigation-grade unit (0.003-0.01 deg/h) is far from.
LATITUDE_SIN_TOLERANCE = 0.25
#: Headers: ``key: value`` or ``key = value`` after the comment prefix.
_HEADER = re.compile(r"^\s*([^:=]+?)\s*[:=]\s*(.*?)\s*$")
#: A header value: a decimal number, optionally followed by a unit word that does not change its meaning.
_NUMBER = re.compile(r"^([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(deg|degrees|°|m|metres|meters|m/s)?$",
                     re.I)
_PARQUET_SUFFIXES = (".parquet", ".pq")
_ROLES = ("gyro x", "gyro y", "gyro z", "accelerometer x", "accelerometer y", "accelerometer z")
_KEYS = ("columns.gyro[0]", "columns.gyro[1]", "columns.gyro[2]", "columns.accelerometer[0]",
         "columns.accelerometer[1]", "columns.accelerometer[2]")


class LogFileError(ValueError):
    """A unit's log broke a rule of its description: one line naming the file, the line or row, and the column."""


@dataclass(frozen=True)
class HeaderValue:
    """A value the log's header carries: the header ``key`` (case-insensitive), its unit's factor to SI.

    ``field`` is the description's key (for messages), ``lo``/``hi`` the allowed range in the header's
    own unit, ``hint`` what a value outside it probably is.
    """

    key: str
    scale: float = 1.0
    field: str = ""
    lo: float | None = None
    hi: float | None = None
    hint: str = ""


@dataclass(frozen=True)
class LogLayout:
    """How a unit's log is laid out (plain values; :mod:`sins_sim.config.log` builds it from YAML).

    Parameters
    ----------
    fmt : {"text", "csv", "parquet"}
        Text with ``header_rows`` header lines then data; CSV whose first row after the header lines is
        the column names; Parquet.
    gyro_columns, accel_columns : tuple of 3 (int or str)
        The log's x, y, z channels: 0-based positions or names (names need CSV or Parquet).
    gyro_kind, accel_kind : {"counts", "totals", "increments", "rates"}
        ``totals``: running pulse totals (a counter read out at each row); the increments are the differences
        of consecutive rows, the first row is the reference.
    gyro_scale, accel_scale : tuple of 3 floats
        SI per logged unit, per channel: rad (counts, totals, increments) or rad/s (rates) per unit for the
        gyros, m/s or m/s^2 per unit for the accelerometers; signed.
    gyro_wrap_bits, accel_wrap_bits : int or None
        Totals: the counter's width in bits when it rolls over (differences wrapped into
        ``[-2^(b-1), 2^(b-1))``).
    axes : 3x3 tuple
        Rows: the log's x, y, z axes expressed in FRD; a rotation (:func:`check_rotation`).
    time_column : int, str or None
        None: a fixed rate ``rate_hz``, the first interval starting at ``start_s``.
    time_scale : float
        Seconds per unit of the time column (``None`` with ``time_count``).
    time_count : bool
        The time column is a sample counter: time = counter / ``rate_hz``.
    time_stamp : {"end", "start"}
        Which end of its interval a row's time marks.
    rate_hz : float or None
        The nominal rate; required without a time column or with a counter.
    jitter : float
        Tolerated distance of a logged time from its grid point, in periods.
    gaps : {"refuse", "fill_mean"}
    delimiter : {"whitespace", "comma", "semicolon", "tab"}
        Text logs (any) and CSV logs (not whitespace).
    header_rows : int
        Lines at the top of a text or CSV log before its data (or names row); searched for header values.
    comment : str
        Lines starting with it (after leading spaces) are skipped; those before the data are header lines.
    site, velocity : dict
        name -> float (SI) or :class:`HeaderValue`: ``lat_rad, lon_rad, height_m`` and
        ``north_m_s, east_m_s, down_m_s``; a missing name is unknown.
    temperature_column : int, str or None
        The unit's temperature (one reading per row), or None.
    temperature_offset : float
        Added to the column to give deg C (``273.15`` subtracted for kelvin: ``-273.15``).
    """

    fmt: str
    gyro_columns: tuple
    accel_columns: tuple
    gyro_kind: str
    accel_kind: str
    gyro_scale: tuple
    accel_scale: tuple
    axes: tuple
    gyro_wrap_bits: int | None = None
    accel_wrap_bits: int | None = None
    time_column: int | str | None = None
    time_scale: float = 1.0
    time_count: bool = False
    time_stamp: str = "end"
    rate_hz: float | None = None
    start_s: float = 0.0
    jitter: float = 0.1
    gaps: str = "refuse"
    delimiter: str = "whitespace"
    header_rows: int = 0
    comment: str = "#"
    site: dict = field(default_factory=dict)
    velocity: dict = field(default_factory=dict)
    temperature_column: int | str | None = None
    temperature_offset: float = 0.0


@dataclass(frozen=True)
class UnitLog:
    """A converted log: ``t_s`` (N,) end of each interval (s), ``dtheta`` (N, 3) rad and ``dv`` (N, 3) m/s in FRD
    body axes (raw: no coning or sculling compensation), and ``report`` (a JSON-able dict: rows read, duplicates
    dropped, gaps and filled intervals, rate, duration, site, initial velocity); ``temperature_c`` (N,) the
    unit's temperature at the row closing each interval (deg C; a filled interval's interpolated), or None."""

    t_s: np.ndarray
    dtheta: np.ndarray
    dv: np.ndarray
    report: dict
    temperature_c: np.ndarray | None = None


# --- axes ----------------------------------------------------------------------------------------------------------
def _letters(text: str) -> str:
    raw = text.strip()
    if re.fullmatch(r"[A-Za-z]{1,6}", raw) and raw.lower() not in AXIS_WORDS:  # letters: "RFU", "rfu", "FR"
        return raw.upper()
    words = [w for w in re.split(r"[\s,;/_\-]+", raw.lower()) if w]
    if len(words) == 6 and [w for w in words[0::2]] == ["x", "y", "z"]:  # "x right, y forward, z up"
        words = words[1::2]
    out = []
    for w in words:
        if w not in AXIS_WORDS:
            raise ValueError(f"{text!r}: {w!r} is not an axis (forward/back, right/left, up/down, or letters F, B, "
                             "R, L, U, D)")
        out.append(AXIS_WORDS[w])
    return "".join(out)


def axes_matrix(text: str) -> np.ndarray:
    """The axes matrix of a convention string: rows = the log's x, y, z axes expressed in FRD.

    ``text`` is a letter triple of F/B (forward/back), R/L (right/left), U/D (up/down) such as ``"RFU"``,
    ``"FLU"``, ``"FRD"``, or long forms (``"right-forward-up"``, ``"x right, y forward, z up"``).

    Raises
    ------
    ValueError
        Not three axes, a letter that is no body axis (N/E are Earth axes), an axis named twice, or a
        left-handed triple (``"FRU"``: F x R = D), naming the rule.

    Examples
    --------
    >>> axes_matrix("RFU")
    array([[ 0.,  1.,  0.],
           [ 1.,  0.,  0.],
           [ 0.,  0., -1.]])
    """
    if not isinstance(text, str):
        raise ValueError(f"must be a convention string or a 3x3 matrix, got {text!r}")
    letters = _letters(text)
    if len(letters) != 3:
        raise ValueError(f"{text!r}: needs three axes (x, y, z), got {len(letters)}")
    bad = [c for c in letters if c not in AXIS_VECTORS]
    if bad:
        earth = " (N, E, S, W are Earth axes, not the body's)" if bad[0] in "NESW" else ""
        raise ValueError(f"{text!r}: {bad[0]!r} is not a body axis{earth}: use F/B (forward/back), R/L "
                         "(right/left), U/D (up/down)")
    pairs = {"F": "F", "B": "F", "R": "R", "L": "R", "U": "U", "D": "U"}
    seen = [pairs[c] for c in letters]
    if len(set(seen)) < 3:
        twice = next(c for c in letters if seen.count(pairs[c]) > 1)
        name = {"F": "forward/back", "R": "right/left", "U": "up/down"}[pairs[twice]]
        raise ValueError(f"{text!r}: names the {name} axis twice (each of x, y, z must be a different axis)")
    m = np.array([AXIS_VECTORS[c] for c in letters])
    if np.linalg.det(m) < 0.0:
        z = np.cross(m[0], m[1])
        want = next(k for k, v in AXIS_VECTORS.items() if np.allclose(v, z))
        raise ValueError(f"{text!r} is left-handed: {letters[0]} x {letters[1]} = {want}, not {letters[2]}, so "
                         f"{letters[:2]}{want} is the right-handed frame; a channel counting against its label "
                         "takes a negative weight")
    return m


def check_rotation(matrix) -> np.ndarray:
    """``matrix`` as a float 3x3 array if it is a proper rotation (orthonormal to :data:`ROTATION_TOLERANCE`,
    determinant +1); ValueError naming the rule otherwise."""
    try:
        m = np.array(matrix, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"must be a convention string or a 3x3 matrix of numbers, got {matrix!r}") from None
    if m.shape != (3, 3):
        raise ValueError(f"a matrix must be 3x3 (rows: the log's x, y, z axes in FRD), got shape {m.shape}")
    if not np.all(np.isfinite(m)):
        raise ValueError("the matrix must be finite")
    worst = float(np.max(np.abs(m @ m.T - np.eye(3))))
    if worst > ROTATION_TOLERANCE:
        raise ValueError(f"not a rotation: rows not orthonormal (largest |C C^T - I| entry {worst:.3g} > "
                         f"{ROTATION_TOLERANCE:g}; write the entries to 7 digits or more)")
    if np.linalg.det(m) < 0.0:
        raise ValueError("not a rotation: determinant -1 (a left-handed frame, a reflection); a channel counting "
                         "against its label takes a negative weight instead")
    return m


# --- reading the raw table -----------------------------------------------------------------------------------------
@dataclass
class _Raw:
    """The log: ``cells[r][j]`` (text: row r's fields as strings) or ``cells[j]`` (Parquet: column j's values),
    ``where[r]`` the line or row of data row r, ``headers`` ``[(label, text)]`` of the header lines, ``names`` the
    column names (None for text), ``row_word`` "line" (text, CSV) or "row" (Parquet)."""

    cells: list
    where: list
    headers: list
    names: list | None
    row_word: str


def _fail(path, message) -> None:
    raise LogFileError(f"{path}: {message}")


def _read_text(path: Path, layout: LogLayout) -> _Raw:
    try:
        raw = path.read_bytes()
    except IsADirectoryError:
        _fail(path, "cannot read: is a directory")
    except OSError as exc:
        _fail(path, f"cannot read: {exc.strerror or exc}")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        _fail(path, f"cannot read: not UTF-8 text (byte {exc.start})")
    lines = text.splitlines()
    if len(lines) < layout.header_rows:
        _fail(path, f"has {len(lines)} lines, fewer than format.header_rows = {layout.header_rows}")
    headers = [(f"line {i + 1}", lines[i]) for i in range(layout.header_rows)]
    comment = layout.comment
    names = None
    data_lines, where = [], []
    for i in range(layout.header_rows, len(lines)):
        s = lines[i].strip()
        if not s:
            continue
        if comment and s.startswith(comment):
            if not data_lines and names is None:
                headers.append((f"line {i + 1}", s))
            continue
        if layout.fmt == "csv" and names is None:
            names = [c.strip() for c in next(csv.reader([s], delimiter=DELIMITERS[layout.delimiter]))]
            continue
        data_lines.append(s)
        where.append(i + 1)
    if layout.fmt == "csv":
        if names is None:
            _fail(path, "has no names row (a CSV log's first line after the header rows and comments)")
        cells = [[c.strip() for c in row] for row in csv.reader(data_lines, delimiter=DELIMITERS[layout.delimiter])]
    else:
        sep = DELIMITERS[layout.delimiter]
        cells = [ln.split(sep) if sep is not None else ln.split() for ln in data_lines]
        if sep is not None:
            cells = [[c.strip() for c in row] for row in cells]
    return _Raw(cells, [f"line {n}" for n in where], headers, names, "line")


def _read_parquet(path: Path) -> _Raw:
    try:
        import pyarrow.parquet as pq

        table = pq.read_table(path)
    except Exception as exc:  # noqa: BLE001 - any reader failure is the file's fault: one line
        _fail(path, f"cannot read as Parquet: {' '.join(str(exc).split())}")
    meta = table.schema.metadata or {}
    headers = []
    for k, v in meta.items():
        key = k.decode("utf-8", "replace")
        if key in ("pandas", "sins_sim", "ARROW:schema"):
            continue
        headers.append((f"metadata key {key!r}", f"{key}: {v.decode('utf-8', 'replace')}"))
    names = [str(n) for n in table.column_names]
    cols = [table.column(j).to_numpy(zero_copy_only=False) for j in range(table.num_columns)]
    return _Raw(cols, [f"row {r + 1}" for r in range(table.num_rows)], headers, names, "row")


def _column_index(path, raw: _Raw, ref, key: str, role: str) -> int:
    if isinstance(ref, str):
        if raw.names is None:
            _fail(path, f"{key}: {ref!r} is a column name, but a text log has no names row: give its 0-based "
                        "position (or describe the file as csv)")
        matches = [j for j, n in enumerate(raw.names) if n == ref]
        if not matches:
            close = [n for n in raw.names if n.lower() == ref.lower()]
            hint = f"; did you mean {close[0]!r}?" if close else ""
            _fail(path, f"{key}: no column {ref!r} ({role}){hint} (columns: {', '.join(raw.names)})")
        if len(matches) > 1:
            _fail(path, f"{key}: the column name {ref!r} ({role}) appears {len(matches)} times")
        return matches[0]
    if raw.names is not None and ref >= len(raw.names):
        _fail(path, f"{key}: column {ref} ({role}) missing: the log has {len(raw.names)} columns (0 to "
                    f"{len(raw.names) - 1})")
    return int(ref)


def _numbers(path, raw: _Raw, j: int, key: str, role: str, integer: bool) -> np.ndarray:
    """Column ``j`` as float64; one line naming the line/row and column for a missing or non-numeric cell."""
    label = f"column {raw.names[j]!r}" if raw.names is not None else f"column {j}"
    if raw.row_word == "row":  # Parquet: typed columns
        col = raw.cells[j]
        try:
            x = np.asarray(col, dtype=np.float64)
        except (TypeError, ValueError):
            x = np.array([_to_float(c) for c in col])
    else:
        short = [r for r, row in enumerate(raw.cells) if len(row) <= j]
        if short:
            r = short[0]
            _fail(path, f"{raw.where[r]}: has {len(raw.cells[r])} fields, {label} ({role}, {key}) needs at least "
                        f"{j + 1}")
        strings = [row[j] for row in raw.cells]
        try:
            x = np.array(strings, dtype=np.float64)
        except ValueError:
            x = np.array([_to_float(c) for c in strings])
    bad = np.flatnonzero(~np.isfinite(x))
    if bad.size:
        r = int(bad[0])
        cell = raw.cells[j][r] if raw.row_word == "row" else raw.cells[r][j]
        _fail(path, f"{raw.where[r]}: {label} ({role}): {cell!r} is not a finite number")
    if integer:
        frac = np.flatnonzero(x != np.rint(x))
        if frac.size:
            r = int(frac[0])
            _fail(path, f"{raw.where[r]}: {label} ({role}): {float(x[r])!r} is not a whole number of pulses (the "
                        "description says counts; increments or rates are not counts)")
    return x


def _to_float(cell) -> float:
    try:
        return float(cell)
    except (TypeError, ValueError):
        return math.nan


# --- header values -------------------------------------------------------------------------------------------------
def _header_table(raw: _Raw, comment: str) -> list:
    """``[(key, value text, label)]`` of every ``key: value`` / ``key = value`` header line."""
    out = []
    for label, text in raw.headers:
        s = text.strip()
        if comment and s.startswith(comment):
            s = s[len(comment):]
        m = _HEADER.match(s)
        if m:
            out.append((m.group(1).strip(), m.group(2), label))
    return out


def _resolve(path, spec, table: list) -> tuple:
    """``(SI value, where it came from)`` of a site or velocity entry."""
    if not isinstance(spec, HeaderValue):
        return float(spec), "description"
    hits = [(v, label) for k, v, label in table if k.casefold() == spec.key.casefold()]
    if not hits:
        keys = ", ".join(dict.fromkeys(k for k, _, _ in table)) or "none"
        _fail(path, f"{spec.field}: no header {spec.key!r} in the log's header rows (header keys found: {keys})")
    values = []
    for text, label in hits:
        m = _NUMBER.match(text)
        if not m:
            _fail(path, f"{label}: header {spec.key!r} = {text!r} is not a decimal number (for {spec.field}; "
                        "write it as a signed decimal, e.g. -33.9 rather than 33 54' S)")
        values.append((float(m.group(1)), label))
    if len({v for v, _ in values}) > 1:
        _fail(path, f"{spec.field}: header {spec.key!r} appears with different values: "
                    + ", ".join(f"{v:g} ({label})" for v, label in values))
    value, label = values[0]
    if (spec.lo is not None and value < spec.lo) or (spec.hi is not None and value > spec.hi):
        _fail(path, f"{label}: header {spec.key!r} = {value:g} for {spec.field}: must lie in [{spec.lo:g}, "
                    f"{spec.hi:g}]{spec.hint}")
    return value * spec.scale, f"header {spec.key!r} ({label})"


# --- the time base -------------------------------------------------------------------------------------------------
def _time_base(path, raw: _Raw, layout: LogLayout, t: np.ndarray, data: np.ndarray) -> tuple:
    """Duplicates dropped, gaps found, grid fitted: ``(keep index, interval number per kept row, dt, report)``."""
    n = t.size
    where = raw.where
    if n < 2:
        _fail(path, f"needs at least 2 data rows, got {n}")
    d = np.diff(t)
    back = np.flatnonzero(d < 0.0)
    if back.size:
        i = int(back[0])
        _fail(path, f"{where[i + 1]}: time goes backwards ({t[i + 1]:.9g} s after {t[i]:.9g} s on {where[i]})")
    if layout.rate_hz is not None:
        dt = 1.0 / layout.rate_hz
    else:
        pos = d[d > 0.0]
        if pos.size == 0:
            _fail(path, "the time column never advances")
        dt = float(np.median(pos))
    k = np.rint(d / dt).astype(np.int64)
    off = np.abs(d - k * dt)
    irregular = np.flatnonzero(off > layout.jitter * dt)
    if irregular.size:
        i = int(irregular[0])
        _fail(path, f"{where[i + 1]}: time step {d[i]:.9g} s from {where[i]} is not a whole number of periods "
                    f"{dt:.9g} s (off by {off[i] / dt:.3g} periods, tolerance time.jitter = {layout.jitter:g})")
    same = np.flatnonzero(k == 0)
    dup = []
    for i in same:
        if np.array_equal(data[i], data[i + 1]):
            dup.append(int(i) + 1)
        else:
            _fail(path, f"{where[i]} and {where[i + 1]} hold the same time ({t[i]:.9g} s) with different data; "
                        "a repeated time is dropped only when the whole row repeats")
    keep = np.ones(n, dtype=bool)
    keep[dup] = False
    idx = np.concatenate([[0], np.cumsum(k)])[keep]
    kept = np.flatnonzero(keep)
    steps = np.diff(idx)
    gap_at = np.flatnonzero(steps > 1)
    gaps = [{"after": where[kept[g]], "before": where[kept[g + 1]], "from_s": float(t[kept[g]]),
             "to_s": float(t[kept[g + 1]]), "missing_intervals": int(steps[g] - 1)} for g in gap_at]
    if gaps and layout.gaps == "refuse":
        g = gaps[0]
        more = f" ({len(gaps)} gaps, {sum(x['missing_intervals'] for x in gaps)} missing intervals in all)" \
            if len(gaps) > 1 else ""
        _fail(path, f"gap between {g['after']} ({g['from_s']:.9g} s) and {g['before']} ({g['to_s']:.9g} s): "
                    f"{g['missing_intervals']} missing interval(s) of {dt:.9g} s{more}; set time.gaps: fill_mean "
                    "to fill them (each filled interval is listed in the output's metadata"
                    + ("; running totals lose nothing across a gap: their difference is shared by its intervals)"
                       if "totals" in (layout.gyro_kind, layout.accel_kind) else ")"))
    if layout.rate_hz is None and idx[-1] > 0:  # least-squares slope of time over interval number
        x = idx - idx.mean()
        dt = float(np.dot(x, t[keep] - t[keep].mean()) / np.dot(x, x))
    grid = t[kept[0]] + dt * idx
    resid = np.abs(t[keep] - grid)
    worst = int(np.argmax(resid))
    if resid[worst] > layout.jitter * dt:
        first = int(np.flatnonzero(resid > layout.jitter * dt)[0])
        _fail(path, f"{where[kept[first]]}: the time column is {resid[first]:.6g} s off the grid of "
                    f"{1.0 / dt:.9g} Hz started at the first row (tolerance time.jitter = {layout.jitter:g} periods; "
                    f"{resid[worst]:.6g} s on {where[kept[worst]]}): the log's clock runs at another rate than "
                    "time.rate_hz, or has jumped")
    report = {"duplicates_dropped": len(dup), "duplicate_rows": [where[i] for i in dup[:20]], "gaps": gaps,
              "timestamp_offset_max_s": float(resid[worst])}
    return keep, idx, dt, report


def _fill(x: np.ndarray, pos: np.ndarray, steps: np.ndarray, share: tuple) -> tuple:
    """The increments on every interval ``0..pos[-1]`` (row r's at ``pos[r]``, ``steps[r]`` intervals after the row
    before it); a gap's missing intervals filled per sensor: the mean of the rows either side, or for running totals
    (``share``) the row's difference shared evenly over the intervals it spans (nothing lost)."""
    out = np.empty((int(pos[-1]) + 1, x.shape[1]))
    out[pos] = x
    filled = np.zeros(out.shape[0], dtype=bool)
    for r in np.flatnonzero(steps > 1):
        s, p = int(steps[r]), int(pos[r])
        for group, shared in zip((slice(0, 3), slice(3, 6)), share):
            if shared:
                out[p - s + 1:p + 1, group] = x[r, group] / s
            else:
                before = x[r - 1, group] if r > 0 else x[r, group]
                out[p - s + 1:p, group] = 0.5 * (before + x[r, group])
        filled[p - s + 1:p] = True
    return out, filled


def _fill_rule(totals: np.ndarray) -> str:
    """How the gaps were filled, in words (for the report)."""
    rules = []
    if totals.any():
        rules.append("running totals: the difference across the gap shared evenly by its intervals")
    if not totals.all():
        rules.append(("other channels: " if totals.any() else "") + "the mean of the increments of the intervals "
                     "either side of the gap")
    return "; ".join(rules)


def _differences(chan: np.ndarray, totals: np.ndarray, wraps) -> np.ndarray:
    """Rows 1.. of ``chan`` with the running-total channels replaced by their differences from the row before,
    wrapped into ``[-2^(b-1), 2^(b-1))`` for a ``b``-bit counter (one that rolls over)."""
    out = chan[1:].copy()
    d = np.diff(chan, axis=0)
    for c in np.flatnonzero(totals):
        if wraps[c]:
            full = float(2 ** int(wraps[c]))
            d[:, c] = np.mod(d[:, c] + full / 2, full) - full / 2
        out[:, c] = d[:, c]
    return out


# --- the latitude the log implies at rest --------------------------------------------------------------------------
def rest_latitude(dtheta, dv, dt: float) -> dict:
    """The latitude a log implies if it starts at rest: what the gyros see of the Earth's rate about the vertical.

    At rest the gyros measure the Earth's rate, whose component along the local up axis is
    ``Omega sin(lat)`` (:func:`sins_sim.earth.earth_rate_ned`), and the accelerometers the specific force
    ``-g``, which points up: the measurements of alignment on a stationary base (Titterton & Weston 2004,
    ch. 10). Over the window at rest, with ``u`` the
    direction of the summed velocity increments, ``sin(lat) = (sum dtheta . u) / (Omega T)``: independent
    of the body axes (both sums turn with them) and of the heading. The window is the longest run of
    one-second blocks from the start, up to :data:`REST_WINDOW_S`, whose mean specific force and rate stay
    close to the first block's (thresholds in this module); fewer than 10 such blocks: no estimate.

    Returns
    -------
    dict
        ``window_s`` (0 when the log does not start at rest), ``latitude_deg`` (None without an estimate),
        ``sin_latitude``.
    """
    per = max(1, int(round(1.0 / dt)))
    nblocks = min(dtheta.shape[0] // per, int(REST_WINDOW_S * per) // per)
    none = {"window_s": 0.0, "latitude_deg": None, "sin_latitude": None}
    if nblocks < _REST_MIN_BLOCKS:
        return none
    w = dtheta[:nblocks * per].reshape(nblocks, per, 3).sum(axis=1) / (per * dt)
    f = dv[:nblocks * per].reshape(nblocks, per, 3).sum(axis=1) / (per * dt)
    still = (np.linalg.norm(f - f[0], axis=1) < _REST_FORCE_M_S2) & \
        (np.linalg.norm(w - w[0], axis=1) < _REST_RATE_EARTH * EARTH_RATE_RAD_S)
    n = int(np.argmin(still)) if not still.all() else nblocks
    g = np.linalg.norm(f[:n].mean(axis=0)) if n else 0.0
    if n < _REST_MIN_BLOCKS or not 9.7 < g < 9.9:  # not at rest on the Earth (normal gravity 9.78-9.83 m/s^2)
        return none
    up = f[:n].sum(axis=0) / np.linalg.norm(f[:n].sum(axis=0))
    s = float(np.dot(w[:n].mean(axis=0), up) / EARTH_RATE_RAD_S)
    lat = math.degrees(math.asin(s)) if abs(s) <= 1.0 else None
    return {"window_s": float(n * per * dt), "latitude_deg": lat, "sin_latitude": s}


def first_motion_s(dtheta, dv, dt: float) -> float | None:
    """When a log that starts at rest first moves: the start (s from the log's start) of the first one-second
    block whose mean specific force or rate leaves the first block's by the thresholds of :func:`rest_latitude`
    (0.05 m/s^2, 5 Earth rates: a vehicle starting or a table turning, far above a soak's drifts, its noise
    averaged over a second, or a vibration line above 1 Hz); None when it stays at rest to its end. A log shorter
    than two blocks: None.
    """
    per = max(1, int(round(1.0 / dt)))
    nblocks = dtheta.shape[0] // per
    if nblocks < 2:
        return None
    w = dtheta[:nblocks * per].reshape(nblocks, per, 3).sum(axis=1) / (per * dt)
    f = dv[:nblocks * per].reshape(nblocks, per, 3).sum(axis=1) / (per * dt)
    moving = (np.linalg.norm(f - f[0], axis=1) >= _REST_FORCE_M_S2) | \
        (np.linalg.norm(w - w[0], axis=1) >= _REST_RATE_EARTH * EARTH_RATE_RAD_S)
    return float(np.argmax(moving) * per * dt) if moving.any() else None


def _check_latitude(path, rest: dict, lat_rad: float, source: str) -> bool | None:
    """Compare the site's latitude with the log's at rest: refuse radians under a ``_deg`` key, warn otherwise."""
    s = rest["sin_latitude"]
    if s is None:
        return None
    if abs(math.sin(lat_rad) - s) <= LATITUDE_SIN_TOLERANCE:
        return True
    given = math.degrees(lat_rad)
    implied = "beyond 90 deg" if rest["latitude_deg"] is None else f"{rest['latitude_deg']:.3g} deg"
    what = (f"site.lat_deg = {given:.6g} deg (from {source}), but the Earth rate the gyros measure about the "
            f"vertical over the log's first {rest['window_s']:g} s at rest implies {implied} (sin {s:.3f})")
    if abs(math.sin(given) - s) <= LATITUDE_SIN_TOLERANCE and abs(given) <= math.pi / 2:
        _fail(path, f"{what}; {given:.6g} rad is {math.degrees(given):.4g} deg: radians under a _deg key? give "
                    "the latitude in degrees")
    warnings.warn(f"{path}: {what}: a wrong site, a unit not at rest, or a gyro channel with the wrong sign or "
                  "weight?", stacklevel=3)
    return False


# --- the whole conversion ------------------------------------------------------------------------------------------
def read_unit_log(path, layout: LogLayout) -> UnitLog:
    """Read a unit's log laid out as ``layout`` and convert it to increments in FRD (see the module docstring).

    Returns
    -------
    UnitLog

    Raises
    ------
    LogFileError
        One line naming the file and the line/row and column (or the description's key): unreadable, a
        missing column, a cell that is not a number (or not a whole number of pulses), too few fields, a
        repeated time with different data, time going backwards, an irregular step, a gap (unless filled),
        a header value missing or out of range.
    """
    p = Path(path)
    if not p.exists():
        _fail(p, "cannot read: no such file")
    fmt = layout.fmt
    if fmt not in ("text", "csv", "parquet"):
        raise ValueError(f"format.type: must be text, csv or parquet, got {fmt!r}")
    raw = _read_parquet(p) if fmt == "parquet" else _read_text(p, layout)
    refs = tuple(layout.gyro_columns) + tuple(layout.accel_columns)
    cols = [_column_index(p, raw, ref, key, role) for ref, key, role in zip(refs, _KEYS, _ROLES)]
    tcol = None
    if layout.time_column is not None:
        tcol = _column_index(p, raw, layout.time_column, "columns.time", "time")
    temp_col = None
    if layout.temperature_column is not None:
        temp_col = _column_index(p, raw, layout.temperature_column, "columns.temperature", "temperature")
    used = ([tcol] if tcol is not None else []) + cols + ([temp_col] if temp_col is not None else [])
    if len(set(used)) < len(used):
        twice = next(c for c in used if used.count(c) > 1)
        _fail(p, f"columns: column {twice} is named for two channels")
    kinds = (layout.gyro_kind,) * 3 + (layout.accel_kind,) * 3
    chan = np.column_stack([_numbers(p, raw, j, key, role, kind in ("counts", "totals"))
                            for j, key, role, kind in zip(cols, _KEYS, _ROLES, kinds)]) \
        if raw.where else np.empty((0, 6))
    n_read = len(raw.where)
    temp = (_numbers(p, raw, temp_col, "columns.temperature", "temperature", False) + layout.temperature_offset
            if temp_col is not None and raw.where else None)
    report = {"file": str(p), "format": fmt, "rows_read": n_read}
    if tcol is not None:
        tc = _numbers(p, raw, tcol, "columns.time", "time", False)
        t = tc / layout.rate_hz if layout.time_count else tc * layout.time_scale
        keep, idx, dt, treport = _time_base(p, raw, layout, t, np.column_stack([tc, chan]))
        chan = chan[keep]
        temp = None if temp is None else temp[keep]
        t_first = float(t[keep][0]) + (dt if layout.time_stamp == "start" else 0.0)
    else:
        if n_read < 2:
            _fail(p, f"needs at least 2 data rows, got {n_read}")
        dt = 1.0 / layout.rate_hz
        idx = np.arange(n_read)
        t_first = layout.start_s + dt
        treport = {"duplicates_dropped": 0, "duplicate_rows": [], "gaps": [], "timestamp_offset_max_s": 0.0,
                   "note": "no time column: duplicates and gaps cannot be seen"}
    totals = np.array([kind == "totals" for kind in kinds])
    if totals.any():  # the first row is the counters' reading before the first interval
        if chan.shape[0] < 3:
            _fail(p, f"needs at least 3 data rows with running totals (the first is the reference), got "
                     f"{chan.shape[0]}")
        chan = _differences(chan, totals, (layout.gyro_wrap_bits,) * 3 + (layout.accel_wrap_bits,) * 3)
        temp = None if temp is None else temp[1:]   # the reading at the row that closes each interval
        steps, pos = np.diff(idx), idx[1:] - idx[0] - 1
        if tcol is not None:  # the first row's time is the reference reading's; without a column, start_s is
            t_first += dt
    else:
        steps, pos = np.r_[1, np.diff(idx)], idx - idx[0]
    scale = np.array(tuple(layout.gyro_scale) + tuple(layout.accel_scale), dtype=np.float64)
    per_dt = np.array([dt if kind == "rates" else 1.0 for kind in kinds])
    x = chan * (scale * per_dt)  # rates: the rectangle rule, x = r dt (module docstring)
    c = np.asarray(layout.axes, dtype=np.float64)
    x = np.concatenate([x[:, :3] @ c, x[:, 3:] @ c], axis=1)  # v_frd^T = v_log^T C (v_log = C v_frd)
    filled_rows = []
    if pos[-1] + 1 != pos.size:
        x, filled = _fill(x, pos, steps, (totals[0], totals[3]))
        filled_rows = np.flatnonzero(filled)
        if temp is not None:  # a slow quantity: linear between the readings either side of a gap
            temp = np.interp(np.arange(x.shape[0]), pos, temp)
    t_s = t_first + dt * np.arange(x.shape[0])
    table = _header_table(raw, layout.comment)
    site, site_from = {}, {}
    for name in ("lat_rad", "lon_rad", "height_m"):
        if name in layout.site and layout.site[name] is not None:
            site[name], site_from[name] = _resolve(p, layout.site[name], table)
    vel, vel_from = [], {}
    for name in ("north_m_s", "east_m_s", "down_m_s"):
        spec = layout.velocity.get(name, 0.0)
        value, src = _resolve(p, 0.0 if spec is None else spec, table)
        vel.append(value)
        vel_from[name] = src
    rest = rest_latitude(x[:, :3], x[:, 3:], dt)
    if "lat_rad" in site:
        rest["agrees_with_site"] = _check_latitude(p, rest, site["lat_rad"], site_from["lat_rad"])
    report.update({
        "rows": int(x.shape[0]), **treport, "rest_check": rest,
        "gaps_filled": len(treport["gaps"]) if len(filled_rows) else 0,
        "filled_intervals": [{"interval": int(i), "end_s": float(t_s[i])} for i in filled_rows],
        "fill_rule": _fill_rule(totals) if len(filled_rows) else None,
        "first_row_reference": bool(totals.any()),
        "rate_hz": 1.0 / dt, "period_s": dt, "start_s": float(t_s[0] - dt), "end_s": float(t_s[-1]),
        "duration_s": float(t_s[-1] - t_s[0] + dt),
        "gyro": layout.gyro_kind, "accelerometer": layout.accel_kind,
        "integration": ("rectangle rule: increment = logged rate x period"
                        if "rates" in (layout.gyro_kind, layout.accel_kind) else None),
        "site": {**site, "from": site_from} if site else None,
        "initial_velocity_ned_m_s": vel, "initial_velocity_from": vel_from,
        "headers": {k: v for k, v, _ in table},
    })
    if temp is not None:
        report["temperature_c"] = {"column": layout.temperature_column, "min": float(np.min(temp)),
                                   "max": float(np.max(temp))}
    return UnitLog(t_s, np.ascontiguousarray(x[:, :3]), np.ascontiguousarray(x[:, 3:]), report, temp)
