"""Trajectory files: a strict reader and a writer of sampled vehicle trajectories.

A trajectory file holds the vehicle's position and attitude (and optionally
its velocity) sampled over time; the simulator interpolates it into
navigation truth (``sins_sim.models.motion.SampledTrajectory.from_data``).

CSV format (``.csv``)
---------------------
Plain text (UTF-8), comma-separated, one header row, then one row per
sample. Lines starting with ``#`` are comments and are allowed only at the
top, before the header; blank lines are allowed only at the end. Spaces
around names and numbers are ignored. Example::

    # level flight at 10 Hz
    time_s,lat_deg,lon_deg,height_m,roll_deg,pitch_deg,yaw_deg
    0.0,45.0,7.0,1000.0,0.0,0.0,0.0
    0.1,45.000134,7.0,1000.0,0.0,0.0,0.0
    ...

Columns (header names exactly as below, each at most once, any order; no
other columns):

==============  =====  ========  =============================================================
column          unit   required  meaning and rule
==============  =====  ========  =============================================================
``time_s``      s      yes       sample time; strictly increasing, steps of at most 1 s
                                 (sample rate >= 1 Hz; the spacing need not be uniform)
``lat_deg``     deg    yes       geodetic latitude (WGS-84), in [-89.5, 89.5] (the NED
                                 mechanisation is singular at the poles, see below)
``lon_deg``     deg    yes       longitude, in [-360, 360]
``height_m``    m      yes       height above the WGS-84 ellipsoid, in [-1000, 100000]
``roll_deg``    deg    yes       Euler angles of the vehicle body (x forward, y right,
``pitch_deg``                    z down) with respect to north-east-down, sequence 3-2-1
``yaw_deg``                      (yaw, then pitch, then roll); |pitch| < 90; roll and yaw in
                                 [-360, 360] (wrapping between rows is allowed)
``vn_m_s``      m/s    no        NED ground velocity; all three or none; |v| <= 3000 m/s
``ve_m_s``
``vd_m_s``
==============  =====  ========  =============================================================

At least 4 rows. Every cell is a finite decimal number (no NaN, no inf, no
empty cell). Between consecutive rows, the position may move at most
3000 m/s (the distance along the local north, east and down axes divided
by the time step), and each Euler angle may change by less than 90 deg and
at most 720 deg/s (roll and yaw the shorter way round, so 359 -> 1 deg is a
2 deg step).

Latitude: the simulator navigates in north-east-down axes, whose transport
rate ``(v_E / (R_E + h), -v_N / (R_N + h), -v_E tan(lat) / (R_E + h))`` and
longitude rate ``v_E / ((R_E + h) cos lat)`` are singular at the poles
(Titterton & Weston 2004, sec. 3.5; Savage 2000, ch. 4 and 5); a polar route
needs a wander-azimuth mechanisation, which is not modelled. Rows beyond
89.5 deg are refused naming the row and ``lat_deg``.

Velocity columns: the velocity is taken as a measurement. The truth is then a
smoothing fit of positions and velocities together
(:mod:`sins_sim.models.motion.smoothing`: fixed-interval Rauch-Tung-Striebel
smoother on a constant-acceleration model, noise levels estimated from the
file), so rounded positions (7 decimals of a degree, 1 cm) and GNSS-grade
velocity noise (0.01-0.1 m/s) are accepted; a velocity column that differs
from the velocity of the positions' own fit by more than the scenario's
``trajectory.velocity_tolerance_m_s`` (default 1 m/s) at some row is refused
naming the row and the column. Without velocity columns the positions are
interpolated (below).

Resolution: the model differentiates the positions twice, so their
rounding shows up in the specific force as about ``6 eps / dt^2`` for a
rounding error ``eps`` (m, half the last digit) at spacing ``dt`` (s): at
10 Hz, 1e-9 deg (0.1 mm) would give ~0.03 m/s^2 and 1 mm of height
~0.3 m/s^2. Write latitude and longitude with 13 decimals (1e-13 deg,
about 1e-8 m) and height with 8 (1e-8 m) for a few 1e-6 m/s^2;
:func:`write_trajectory` does so by default (float64 holds these digits
for |angles| up to 360 deg and heights up to 100 km).

Parquet format (``.parquet``, ``.pq``)
--------------------------------------
The same columns (names, units, rules) as numeric (floating point or
integer) columns without nulls; the row number in messages is the 1-based
row. Needs ``pyarrow``. Comments are kept in the schema metadata key
``sins_sim.comments``.

Errors
------
A file that breaks a rule raises one :class:`TrajectoryFileError` (a
``ValueError``) naming the file, the row (1-based data row, and the line of
the file for CSV) or the column, and the rule, e.g. ``trajectory file
f.csv: row 12 (line 14), column pitch_deg: |pitch| must be < 90 deg, got
91.5``.

.. autosummary::

   TrajectoryData
   read_trajectory
   write_trajectory
   TRAJECTORY_COLUMNS
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sins_sim import earth
from sins_sim.units import DEG

__all__ = ["TRAJECTORY_COLUMNS", "REQUIRED_COLUMNS", "VELOCITY_COLUMNS", "TrajectoryFileError", "TrajectoryData",
           "read_trajectory", "write_trajectory", "MAX_SPEED_M_S", "MAX_ANGLE_RATE_DEG_S", "MAX_ANGLE_STEP_DEG",
           "MAX_TIME_STEP_S", "MIN_ROWS", "HEIGHT_RANGE_M", "MAX_ABS_LAT_DEG", "POLE_REASON"]

#: Required columns, in the order the writer uses.
REQUIRED_COLUMNS = ("time_s", "lat_deg", "lon_deg", "height_m", "roll_deg", "pitch_deg", "yaw_deg")
#: Optional velocity columns (all three or none).
VELOCITY_COLUMNS = ("vn_m_s", "ve_m_s", "vd_m_s")
#: Every column a trajectory file may have.
TRAJECTORY_COLUMNS = REQUIRED_COLUMNS + VELOCITY_COLUMNS
#: Largest speed (m/s) implied by the position change between rows, and largest |velocity|.
MAX_SPEED_M_S = 3000.0
#: Largest Euler-angle rate (deg/s) implied by the change between rows.
MAX_ANGLE_RATE_DEG_S = 720.0
#: Euler angles must change by less than this (deg) between rows (unambiguous unwrapping).
MAX_ANGLE_STEP_DEG = 90.0
#: Largest time step (s) between rows: the sample rate is at least 1 Hz.
MAX_TIME_STEP_S = 1.0
#: Fewest rows of a file.
MIN_ROWS = 4
#: Allowed heights (m).
HEIGHT_RANGE_M = (-1000.0, 100000.0)
#: Largest |latitude| (deg) of a trajectory: the simulator navigates in a north-east-down frame (sins_sim.earth).
MAX_ABS_LAT_DEG = earth.MAX_ABS_LAT_DEG
#: Why (for messages and the schema reference).
POLE_REASON = ("the north-east-down mechanisation's transport rate has tan(lat) and sec(lat) terms, singular at the "
               "poles (Titterton & Weston 2004, sec. 3.5); a polar route needs a wander-azimuth mechanisation, "
               "which sins-sim does not model")

_PARQUET_SUFFIXES = (".parquet", ".pq")
_COMMENT_KEY = b"sins_sim.comments"


class TrajectoryFileError(ValueError):
    """A trajectory file or array broke a rule of the format; the message names the row or column and the rule."""


# --- validation shared by files and arrays ------------------------------------------


def _wrap180(x):
    return (x + 180.0) % 360.0 - 180.0


class _Checker:
    """Raise one error naming where (file or object), the row or sample, the column or field, and the rule."""

    def __init__(self, where, row_label, col_label):
        self.where = where
        self.row_label = row_label
        self.col_label = col_label

    def fail(self, rule, row=None, col=None):
        place = [x for x in (None if row is None else self.row_label(row),
                             None if col is None else self.col_label(col)) if x]
        raise TrajectoryFileError(f"{self.where}: " + (", ".join(place) + ": " if place else "") + rule)

    def check_bad(self, mask, rule_of, col):
        bad = np.flatnonzero(mask)
        if bad.size:
            self.fail(rule_of(int(bad[0])), row=int(bad[0]), col=col)


def _check_values(cols, chk: _Checker):
    """All rules on the columns (file units: deg, m, s, m/s), in a fixed order; first violation raises.

    ``cols`` maps each present column name of :data:`TRAJECTORY_COLUMNS` to a float64 array.
    """
    n = cols["time_s"].size
    if n < MIN_ROWS:
        raise TrajectoryFileError(f"{chk.where}: column time_s: needs at least {MIN_ROWS} rows, got {n}")
    for name, arr in cols.items():
        chk.check_bad(~np.isfinite(arr), lambda i, a=arr: f"must be a finite number, got {float(a[i])!r}", name)
    t = cols["time_s"]
    dt = np.diff(t)
    chk.check_bad(np.r_[False, ~(dt > 0.0)],
                  lambda i: f"time must be strictly increasing, got {float(t[i])!r} after {float(t[i - 1])!r}",
                  "time_s")
    chk.check_bad(np.r_[False, dt > MAX_TIME_STEP_S],
                  lambda i: f"step of {float(t[i] - t[i - 1])!r} s from the previous row exceeds {MAX_TIME_STEP_S} s "
                            "(the sample rate must be >= 1 Hz)", "time_s")
    lat, lon, h = cols["lat_deg"], cols["lon_deg"], cols["height_m"]
    chk.check_bad(np.abs(lat) > MAX_ABS_LAT_DEG,
                  lambda i: f"latitude must be in [-{MAX_ABS_LAT_DEG:g}, {MAX_ABS_LAT_DEG:g}] deg, got "
                            f"{float(lat[i])!r} ({POLE_REASON})", "lat_deg")
    chk.check_bad(np.abs(lon) > 360.0, lambda i: f"longitude must be in [-360, 360] deg, got {float(lon[i])!r}",
                  "lon_deg")
    lo, hi = HEIGHT_RANGE_M
    chk.check_bad((h < lo) | (h > hi), lambda i: f"height must be in [{lo:g}, {hi:g}] m, got {float(h[i])!r}",
                  "height_m")
    pitch = cols["pitch_deg"]
    chk.check_bad(np.abs(pitch) >= 90.0, lambda i: f"|pitch| must be < 90 deg, got {float(pitch[i])!r}",
                  "pitch_deg")
    for name in ("roll_deg", "yaw_deg"):
        a = cols[name]
        chk.check_bad(np.abs(a) > 360.0, lambda i, a=a, name=name: f"{name[:-4]} must be in [-360, 360] deg, "
                                                                   f"got {float(a[i])!r}", name)
    if "vn_m_s" in cols:
        speed = np.sqrt(cols["vn_m_s"] ** 2 + cols["ve_m_s"] ** 2 + cols["vd_m_s"] ** 2)
        chk.check_bad(speed > MAX_SPEED_M_S, lambda i: f"|velocity| must be <= {MAX_SPEED_M_S:g} m/s, got "
                                                       f"{float(speed[i])!r}", "vn_m_s")
    # Position jumps: local north/east/down distance over the step.
    r_n, r_e = earth.radii(lat[:-1] * DEG)
    d_n = (lat[1:] - lat[:-1]) * DEG * (r_n + h[:-1])
    d_e = _wrap180(lon[1:] - lon[:-1]) * DEG * np.cos(lat[:-1] * DEG) * (r_e + h[:-1])
    d_d = h[1:] - h[:-1]
    dist = np.sqrt(d_n ** 2 + d_e ** 2 + d_d ** 2)
    bad = np.flatnonzero(dist > MAX_SPEED_M_S * dt)
    if bad.size:
        i = int(bad[0]) + 1
        chk.fail(f"position jump of {dist[i - 1]:.6g} m in {dt[i - 1]:.6g} s from the previous row implies "
                 f"{dist[i - 1] / dt[i - 1]:.6g} m/s > {MAX_SPEED_M_S:g} m/s (lat_deg, lon_deg, height_m)", row=i)
    for name in ("roll_deg", "pitch_deg", "yaw_deg"):
        a = cols[name]
        step = np.diff(a) if name == "pitch_deg" else _wrap180(np.diff(a))
        mag = np.abs(step)
        bad = np.flatnonzero((mag >= MAX_ANGLE_STEP_DEG) | (mag > MAX_ANGLE_RATE_DEG_S * dt))
        if bad.size:
            i = int(bad[0]) + 1
            chk.fail(f"change of {step[i - 1]:.6g} deg in {dt[i - 1]:.6g} s from the previous row "
                     f"({mag[i - 1] / dt[i - 1]:.6g} deg/s) must be < {MAX_ANGLE_STEP_DEG:g} deg and "
                     f"<= {MAX_ANGLE_RATE_DEG_S:g} deg/s", row=i, col=name)


# --- the data --------------------------------------------------------------------


_FIELD_OF = {"time_s": "t_s", "lat_deg": "lat_rad", "lon_deg": "lon_rad", "height_m": "h_m", "roll_deg": "roll_rad",
             "pitch_deg": "pitch_rad", "yaw_deg": "yaw_rad", "vn_m_s": "v_ned_m_s[:, 0]", "ve_m_s": "v_ned_m_s[:, 1]",
             "vd_m_s": "v_ned_m_s[:, 2]"}
_ANGLE_COLUMNS = ("lat_deg", "lon_deg", "roll_deg", "pitch_deg", "yaw_deg")


@dataclass(frozen=True, eq=False)
class TrajectoryData:
    """A validated sampled trajectory in SI units and rad (read-only float64 arrays).

    Parameters
    ----------
    t_s : array_like (N,)
        Sample times (s).
    lat_rad, lon_rad : array_like (N,)
        Geodetic latitude and longitude (rad).
    h_m : array_like (N,)
        Height above the ellipsoid (m).
    roll_rad, pitch_rad, yaw_rad : array_like (N,)
        Euler angles 3-2-1, vehicle body (x forward, y right, z down) w.r.t. NED (rad).
    v_ned_m_s : array_like (N, 3), optional
        NED velocity (m/s).
    source : str
        Where the data came from (a file name), for messages.

    Notes
    -----
    The constructor applies the rules of the file format (module docstring)
    to the arrays, converted to deg; errors name the field and the 0-based
    sample.
    """

    t_s: np.ndarray
    lat_rad: np.ndarray
    lon_rad: np.ndarray
    h_m: np.ndarray
    roll_rad: np.ndarray
    pitch_rad: np.ndarray
    yaw_rad: np.ndarray
    v_ned_m_s: np.ndarray | None = None
    source: str = ""

    def __post_init__(self):
        self._init(check=True)

    def _init(self, check):
        names = ("t_s", "lat_rad", "lon_rad", "h_m", "roll_rad", "pitch_rad", "yaw_rad")
        arrs = {}
        for name in names:
            try:
                arr = np.array(getattr(self, name), dtype=np.float64)
            except (TypeError, ValueError) as exc:
                raise TrajectoryFileError(f"TrajectoryData.{name}: must be an array of numbers ({exc})") from None
            if arr.ndim != 1:
                raise TrajectoryFileError(f"TrajectoryData.{name}: must be 1-D, got shape {arr.shape}")
            arrs[name] = arr
        n = arrs["t_s"].size
        for name, arr in arrs.items():
            if arr.size != n:
                raise TrajectoryFileError(f"TrajectoryData.{name}: must have the length of t_s ({n}), got {arr.size}")
        vel = None
        if self.v_ned_m_s is not None:
            try:
                vel = np.array(self.v_ned_m_s, dtype=np.float64)
            except (TypeError, ValueError) as exc:
                raise TrajectoryFileError(f"TrajectoryData.v_ned_m_s: must be an array of numbers ({exc})") from None
            if vel.shape != (n, 3):
                raise TrajectoryFileError(f"TrajectoryData.v_ned_m_s: must have shape ({n}, 3), got {vel.shape}")
        if check:
            cols = _columns_from_arrays(arrs, vel)
            _check_values(cols, _Checker(self.source or "TrajectoryData", lambda i: f"sample {i}",
                                         lambda c: f"field {_FIELD_OF[c]}" + (" (in deg)" if c in _ANGLE_COLUMNS
                                                                               else "")))
        for name, arr in arrs.items():
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        if vel is not None:
            vel.setflags(write=False)
        object.__setattr__(self, "v_ned_m_s", vel)
        object.__setattr__(self, "source", str(self.source))

    def __len__(self) -> int:
        return int(self.t_s.size)


def _columns_from_arrays(arrs, vel):
    cols = {"time_s": arrs["t_s"], "lat_deg": arrs["lat_rad"] / DEG, "lon_deg": arrs["lon_rad"] / DEG,
            "height_m": arrs["h_m"], "roll_deg": arrs["roll_rad"] / DEG, "pitch_deg": arrs["pitch_rad"] / DEG,
            "yaw_deg": arrs["yaw_rad"] / DEG}
    if vel is not None:
        cols.update(vn_m_s=vel[:, 0], ve_m_s=vel[:, 1], vd_m_s=vel[:, 2])
    return cols


def _data_from_columns(cols, source):
    """A :class:`TrajectoryData` from columns already checked in file units (no second check in rad)."""
    vel = np.stack([cols[c] for c in VELOCITY_COLUMNS], axis=-1) if "vn_m_s" in cols else None
    data = object.__new__(TrajectoryData)
    for name, val in (("t_s", cols["time_s"]), ("lat_rad", cols["lat_deg"] * DEG), ("lon_rad", cols["lon_deg"] * DEG),
                      ("h_m", cols["height_m"]), ("roll_rad", cols["roll_deg"] * DEG),
                      ("pitch_rad", cols["pitch_deg"] * DEG), ("yaw_rad", cols["yaw_deg"] * DEG),
                      ("v_ned_m_s", vel), ("source", source)):
        object.__setattr__(data, name, val)
    data._init(check=False)
    return data


def _check_header(names, fail):
    """Column names: no duplicates, nothing unknown, all required, velocity all or none."""
    seen = set()
    for name in names:
        if name in seen:
            fail(f"column {name!r} appears more than once")
        seen.add(name)
    for name in names:
        if name not in TRAJECTORY_COLUMNS:
            fail(f"unknown column {name!r}; allowed: {', '.join(TRAJECTORY_COLUMNS)}")
    for name in REQUIRED_COLUMNS:
        if name not in seen:
            fail(f"missing required column {name!r}")
    vel = [c for c in VELOCITY_COLUMNS if c in seen]
    if vel and len(vel) != 3:
        missing = [c for c in VELOCITY_COLUMNS if c not in seen]
        fail(f"velocity columns {', '.join(VELOCITY_COLUMNS)} come all three or none; missing {', '.join(missing)}")


# --- reading -------------------------------------------------------------------------


def _number(text):
    """A CSV cell as float: a decimal number (Python's float syntax without ``_`` separators)."""
    text = text.strip()
    if "_" in text:
        raise ValueError(text)
    return float(text)


def read_trajectory(path) -> TrajectoryData:
    """Read and validate a trajectory file (CSV or Parquet, by suffix); see the module docstring for the format.

    Parameters
    ----------
    path : str or Path
        ``*.csv``, ``*.parquet`` or ``*.pq``.

    Returns
    -------
    TrajectoryData
        Arrays in s, rad, m and m/s; ``source`` is the path.

    Raises
    ------
    TrajectoryFileError
        (a ``ValueError``) a missing or unreadable file, an unknown suffix, or
        a broken rule; the message names the row and/or column and the rule.

    Examples
    --------
    >>> from pathlib import Path
    >>> path = Path(__file__).resolve().parents[2] / "scenarios" / "trajectories" / "short-flight.csv"
    >>> data = read_trajectory(path)
    >>> len(data) > 1000, data.v_ned_m_s is not None
    (True, True)
    """
    p = Path(path)
    where = f"trajectory file {p}"
    if not p.is_file():
        raise TrajectoryFileError(f"{where}: does not exist" if not p.exists() else f"{where}: is not a file")
    return _read_table(p, where)


def _read_table(p, where):
    cols, row_label = read_numeric_table(p, where, TrajectoryFileError, _check_header, REQUIRED_COLUMNS, MIN_ROWS)
    _check_values(cols, _Checker(where, row_label, lambda c: f"column {c}"))
    return _data_from_columns(cols, str(p))


def read_numeric_table(p, where: str, error, check_header, required, min_rows: int):
    """The columns of a numeric table file: CSV (``#`` comment lines, a header row of names, comma-separated
    numbers) or Parquet (numeric columns without nulls), by suffix; shared by the trajectory and GNSS files.

    Parameters
    ----------
    p : Path
        The file (it exists).
    where : str
        The file as messages name it.
    error : type
        The ``ValueError`` subclass raised, with one line naming the row, the line and the column.
    check_header : callable(names, fail)
        The format's rules on the column names; ``fail(rule)`` raises.
    required : sequence of str
        The required columns (named when the header row is missing).
    min_rows : int
        Named when the file holds a header and no data.

    Returns
    -------
    (dict, callable)
        ``name -> float64 array`` and ``row_label(r)`` naming a row (and its line, for CSV) in messages.
    """
    suffix = p.suffix.lower()
    if suffix in _PARQUET_SUFFIXES:
        return _parquet_columns(p, where, error, check_header)
    if suffix != ".csv":
        raise error(f"{where}: unknown suffix {p.suffix!r}; use .csv, .parquet or .pq")
    try:
        text = p.read_text(encoding="utf-8-sig")  # a byte-order mark is allowed
    except (OSError, UnicodeDecodeError) as exc:
        raise error(f"{where}: cannot be read as UTF-8 text ({exc})") from None
    lines = text.splitlines()
    i = 0
    while i < len(lines) and lines[i].lstrip().startswith("#"):
        i += 1
    if i == len(lines) or not lines[i].strip():
        raise error(f"{where}: line {i + 1}: expected the header row ({','.join(required)}) after the comments")
    header_line = i + 1

    def header_fail(rule):
        raise error(f"{where}: header (line {header_line}): {rule}")

    names = [c.strip() for c in lines[i].split(",")]
    check_header(names, header_fail)
    body = lines[i + 1:]
    while body and not body[-1].strip():  # blank lines at the end
        body.pop()
    rows, line_no = [], []
    ncol = len(names)
    for j, line in enumerate(body):
        ln = header_line + 1 + j
        r = j + 1
        if not line.strip():
            raise error(f"{where}: row {r} (line {ln}): empty line inside the data")
        cells = line.split(",")
        if len(cells) != ncol:
            raise error(f"{where}: row {r} (line {ln}): expected {ncol} comma-separated cells "
                        f"(one per header column), got {len(cells)}")
        rows.append(cells)
        line_no.append(ln)
    if not rows:
        raise error(f"{where}: column {required[0]}: needs at least {min_rows} rows, got 0: the file holds a header "
                    "and no data")
    try:
        values = np.array([[_number(x) for x in cells] for cells in rows])
    except ValueError:
        for r, cells in enumerate(rows):
            for c, x in enumerate(cells):
                try:
                    _number(x)
                except ValueError:
                    raise error(f"{where}: row {r + 1} (line {line_no[r]}), column {names[c]}: "
                                f"must be a number, got {x.strip()!r}") from None
        raise  # pragma: no cover - the scan above finds the cell
    cols = {name: np.ascontiguousarray(values[:, c]) for c, name in enumerate(names)}
    return cols, lambda r: f"row {r + 1} (line {line_no[r]})"


def _parquet_columns(p, where, error, check_header):
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:  # pragma: no cover - pyarrow is a dependency
        raise error(f"{where}: reading Parquet needs pyarrow, which is not installed") from None
    try:
        table = pq.read_table(p)
    except (OSError, pa.ArrowException) as exc:
        raise error(f"{where}: not a readable Parquet file ({exc})") from None

    def header_fail(rule):
        raise error(f"{where}: {rule}")

    names = list(table.column_names)
    check_header(names, header_fail)
    cols = {}
    for name in names:
        col = table.column(name)
        if not (pa.types.is_floating(col.type) or pa.types.is_integer(col.type)):
            raise error(f"{where}: column {name}: must be numeric (float or integer), got {col.type}")
        if col.null_count:
            r = int(np.flatnonzero(np.asarray(col.is_null()))[0])
            raise error(f"{where}: row {r + 1}, column {name}: must be a number, got null")
        cols[name] = np.ascontiguousarray(col.to_numpy(), dtype=np.float64)
    return cols, lambda r: f"row {r + 1}"


# --- writing -------------------------------------------------------------------------


def write_trajectory(path, data, *, comments=(), time_decimals: int = 6, angle_decimals: int = 13,
                     height_decimals: int = 8, velocity_decimals: int = 6) -> Path:
    """Write a :class:`TrajectoryData` (or an object with its fields) as CSV or Parquet (by suffix).

    Parameters
    ----------
    path : str or Path
        ``*.csv``, ``*.parquet`` or ``*.pq``.
    data : TrajectoryData or object
        Validated here (through :class:`TrajectoryData`) before writing.
    comments : sequence of str
        Comment lines (without ``#``), written at the top of a CSV, or into the
        Parquet metadata.
    time_decimals, angle_decimals, height_decimals, velocity_decimals : int
        CSV decimals of s, deg (latitude, longitude, Euler angles), m and m/s
        (defaults 6, 13, 8, 6; see the module docstring on resolution).
        Parquet stores float64 values unrounded.

    Returns
    -------
    Path
        The written file.
    """
    if not isinstance(data, TrajectoryData):
        data = TrajectoryData(**{k: getattr(data, k) for k in ("t_s", "lat_rad", "lon_rad", "h_m", "roll_rad",
                                                              "pitch_rad", "yaw_rad")},
                              v_ned_m_s=getattr(data, "v_ned_m_s", None), source=str(path))
    p = Path(path)
    comments = [str(c) for c in comments]
    for c in comments:
        if "\n" in c or "\r" in c:
            raise ValueError(f"write_trajectory.comments: one line each (no newline), got {c!r}")
    cols = _columns_from_arrays({k: getattr(data, k) for k in ("t_s", "lat_rad", "lon_rad", "h_m", "roll_rad",
                                                               "pitch_rad", "yaw_rad")}, data.v_ned_m_s)
    names = [c for c in TRAJECTORY_COLUMNS if c in cols]
    suffix = p.suffix.lower()
    if suffix in _PARQUET_SUFFIXES:
        import pyarrow as pa
        import pyarrow.parquet as pq

        table = pa.table({name: pa.array(cols[name], type=pa.float64()) for name in names})
        table = table.replace_schema_metadata({_COMMENT_KEY: "\n".join(comments).encode()})
        pq.write_table(table, p)
        return p
    if suffix != ".csv":
        raise ValueError(f"write_trajectory.path: unknown suffix {p.suffix!r}; use .csv, .parquet or .pq")
    for key, val in (("time_decimals", time_decimals), ("angle_decimals", angle_decimals),
                     ("height_decimals", height_decimals), ("velocity_decimals", velocity_decimals)):
        if isinstance(val, bool) or not isinstance(val, (int, np.integer)) or not 0 <= val <= 17:
            raise ValueError(f"write_trajectory.{key}: must be an integer in [0, 17], got {val!r}")
    dec = {"time_s": time_decimals, "height_m": height_decimals}
    dec.update({c: angle_decimals for c in _ANGLE_COLUMNS})
    dec.update({c: velocity_decimals for c in VELOCITY_COLUMNS})
    fmt = ",".join(f"%.{dec[c]}f" for c in names)
    # Values that print as zero are written as 0, not -0.
    table = np.stack([np.where(np.abs(cols[c]) < 0.5 * 10.0 ** -dec[c], 0.0, cols[c]) for c in names], axis=-1)
    with open(p, "w", encoding="utf-8", newline="\n") as fh:
        for c in comments:
            fh.write(f"# {c}\n" if c else "#\n")
        fh.write(",".join(names) + "\n")
        np.savetxt(fh, table, fmt=fmt)
    return p
