"""GNSS solution files: a strict reader and a writer of recorded position (and velocity) fixes (issue 37).

A GNSS file holds a receiver's solution at its antenna, one row per fix, for ``aiding.file`` of a scenario.
CSV (``.csv``: comments ``#`` only at the top, one header row, comma-separated) or Parquet (``.parquet``,
``.pq``: numeric columns, no nulls), with the columns (header names exactly, each at most once, any order, no
others):

==============  =====  ========  ===========================================================
column          unit   required  meaning and rule
==============  =====  ========  ===========================================================
``time_s``      s      yes       time of validity of the fix; strictly increasing
``lat_deg``     deg    yes       geodetic latitude (WGS-84) of the antenna, in [-89.5, 89.5]
``lon_deg``     deg    yes       longitude, in [-360, 360]
``height_m``    m      yes       height above the WGS-84 ellipsoid, in [-1000, 100000]
``vn_m_s``      m/s    no        NED velocity of the antenna; all three or none; |v| <= 3000
``ve_m_s``
``vd_m_s``
==============  =====  ========  ===========================================================

At least 2 rows; every cell a finite number. Between consecutive rows the position moves at most 3000 m/s
(the rule of trajectory files, :mod:`sins_sim.io.trajectory`). A broken rule raises one
:class:`GnssFileError` naming the file, the row (and the line of a CSV) or the column, and the rule.

.. autosummary::

   GnssFile
   read_gnss_file
   write_gnss_file
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sins_sim import earth
from sins_sim.io.trajectory import HEIGHT_RANGE_M, MAX_ABS_LAT_DEG, MAX_SPEED_M_S, read_numeric_table
from sins_sim.units import DEG

__all__ = ["GnssFileError", "GnssFile", "read_gnss_file", "write_gnss_file", "GNSS_COLUMNS"]

_REQUIRED = ("time_s", "lat_deg", "lon_deg", "height_m")
_VELOCITY = ("vn_m_s", "ve_m_s", "vd_m_s")
#: Every column a GNSS file may have.
GNSS_COLUMNS = _REQUIRED + _VELOCITY
_MIN_ROWS = 2


class GnssFileError(ValueError):
    """A GNSS file broke a rule of the format; the message names the row or column and the rule."""


@dataclass(frozen=True)
class GnssFile:
    """A recorded GNSS solution in SI (s, rad, m, m/s).

    Attributes
    ----------
    t_s, lat_rad, lon_rad, h_m : ndarray, shape (K,)
        Time of validity and antenna position.
    v_ned_m_s : ndarray, shape (K, 3) or None
        Antenna velocity NED, or None without velocity columns.
    source : str
        The file read.
    """

    t_s: np.ndarray
    lat_rad: np.ndarray
    lon_rad: np.ndarray
    h_m: np.ndarray
    v_ned_m_s: np.ndarray | None
    source: str = ""

    def __len__(self) -> int:
        return int(self.t_s.shape[0])


def _check(cols: dict, where: str, row_label) -> None:
    def fail(r, col, rule):
        raise GnssFileError(f"{where}: {row_label(r)}, column {col}: {rule}")

    for name, x in cols.items():
        bad = np.flatnonzero(~np.isfinite(x))
        if bad.size:
            fail(int(bad[0]), name, f"must be a finite number, got {x[bad[0]]!r}")
    n = cols["time_s"].shape[0]
    if n < _MIN_ROWS:
        raise GnssFileError(f"{where}: column time_s: needs at least {_MIN_ROWS} rows, got {n}")
    dt = np.diff(cols["time_s"])
    bad = np.flatnonzero(dt <= 0.0)
    if bad.size:
        fail(int(bad[0]) + 1, "time_s", f"must be strictly increasing, got {cols['time_s'][bad[0] + 1]!r} after "
                                        f"{cols['time_s'][bad[0]]!r}")
    for name, lo, hi in (("lat_deg", -MAX_ABS_LAT_DEG, MAX_ABS_LAT_DEG), ("lon_deg", -360.0, 360.0),
                         ("height_m", HEIGHT_RANGE_M[0], HEIGHT_RANGE_M[1])):
        x = cols[name]
        bad = np.flatnonzero((x < lo) | (x > hi))
        if bad.size:
            unit = "deg" if name.endswith("deg") else "m"
            fail(int(bad[0]), name, f"must be in [{lo:g}, {hi:g}] {unit}, got {x[bad[0]]!r}"
                 + (" (radians are refused: the column is in degrees)" if unit == "deg" else ""))
    if "vn_m_s" in cols:
        speed = np.sqrt(sum(cols[c] ** 2 for c in _VELOCITY))
        bad = np.flatnonzero(speed > MAX_SPEED_M_S)
        if bad.size:
            fail(int(bad[0]), "vn_m_s", f"|v| must be <= {MAX_SPEED_M_S:g} m/s, got {speed[bad[0]]:.6g}")
    lat = cols["lat_deg"] * DEG
    r_n, r_e = earth.radii(lat)
    h = cols["height_m"]
    dlon = (np.diff(cols["lon_deg"]) + 180.0) % 360.0 - 180.0
    step = np.sqrt((np.diff(lat) * (r_n[1:] + h[1:])) ** 2 + (dlon * DEG * (r_e[1:] + h[1:]) * np.cos(lat[1:])) ** 2
                   + np.diff(h) ** 2) / dt
    bad = np.flatnonzero(step > MAX_SPEED_M_S)
    if bad.size:
        fail(int(bad[0]) + 1, "lat_deg", f"the position moves {step[bad[0]]:.6g} m/s from the row before, more than "
                                         f"{MAX_SPEED_M_S:g} m/s")


def _header(names, fail):
    unknown = [n for n in names if n not in GNSS_COLUMNS]
    if unknown:
        fail(f"unknown column {unknown[0]!r}; the columns are {', '.join(GNSS_COLUMNS)} (units in the names)")
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        fail(f"column {dup[0]} appears more than once")
    missing = [n for n in _REQUIRED if n not in names]
    if missing:
        fail(f"missing required column {missing[0]}")
    vel = [n for n in _VELOCITY if n in names]
    if vel and len(vel) != 3:
        fail(f"the velocity columns {', '.join(_VELOCITY)} come all three or none, got {', '.join(vel)}")


def read_gnss_file(path) -> GnssFile:
    """Read and check a GNSS solution file (module docstring); CSV or Parquet by suffix.

    Raises
    ------
    GnssFileError
        A missing or unreadable file, an unknown suffix, or a broken rule (the message names the row and column).
    """
    p = Path(path)
    where = f"GNSS file {p}"
    if not p.is_file():
        raise GnssFileError(f"{where}: does not exist" if not p.exists() else f"{where}: is not a file")
    cols, row_label = read_numeric_table(p, where, GnssFileError, _header, _REQUIRED, _MIN_ROWS)
    _check(cols, where, row_label)
    vel = np.column_stack([cols[c] for c in _VELOCITY]) if "vn_m_s" in cols else None
    return GnssFile(cols["time_s"], cols["lat_deg"] * DEG, cols["lon_deg"] * DEG, cols["height_m"], vel, str(p))


def write_gnss_file(path, t_s, lat_rad, lon_rad, h_m, v_ned_m_s=None) -> Path:
    """Write fixes (SI arrays) as a GNSS file (CSV with 13 decimals of a degree and 8 of a metre, or Parquet
    unrounded; by suffix). Returns the path."""
    import pandas as pd

    p = Path(path)
    cols = {"time_s": np.asarray(t_s, dtype=np.float64), "lat_deg": np.degrees(lat_rad),
            "lon_deg": np.degrees(lon_rad), "height_m": np.asarray(h_m, dtype=np.float64)}
    if v_ned_m_s is not None:
        v = np.asarray(v_ned_m_s, dtype=np.float64).reshape(-1, 3)
        cols.update({c: v[:, i] for i, c in enumerate(_VELOCITY)})
    df = pd.DataFrame(cols)
    suffix = p.suffix.lower()
    if suffix == ".csv":
        fmt = {"time_s": "{:.9f}", "lat_deg": "{:.13f}", "lon_deg": "{:.13f}", "height_m": "{:.8f}"}
        lines = [",".join(df.columns)]
        for row in df.itertuples(index=False):
            lines.append(",".join(fmt.get(c, "{:.8f}").format(x) for c, x in zip(df.columns, row)))
        p.write_text("\n".join(lines) + "\n")
    elif suffix in (".parquet", ".pq"):
        df.to_parquet(p, index=False)
    else:
        raise GnssFileError(f"GNSS file {p}: unknown suffix {p.suffix!r}; use .csv, .parquet or .pq")
    return p
