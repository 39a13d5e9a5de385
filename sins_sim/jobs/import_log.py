"""``sins-sim import-log LOG --describe LOG.yaml --out log.parquet``: a unit's own log as an increments file.

The log is read as its description says (:mod:`sins_sim.config.log`, ``sins-sim schema log``) and
converted by :func:`sins_sim.io.unitlog.read_unit_log` to angle and velocity increments in body FRD axes;
the output is a Parquet file with exactly the columns :data:`sins_sim.jobs.navigate.INCREMENT_COLUMNS`, so
:func:`~sins_sim.jobs.navigate.read_increments` and ``sins-sim navigate`` read it as it is. Its key-value
metadata (key :data:`META_KEY`, JSON) records where it came from: the resolved description, the site,
the initial velocity, the source file's SHA-256, the sins-sim version and the report of the time base
(rows read, duplicates dropped, gaps, filled intervals). :func:`read_log_table` returns it.

API: :func:`import_log` (what the command runs), :func:`read_log_table`, :func:`write_log_table`.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from sins_sim.config.errors import ConfigError
from sins_sim.jobs.navigate import INCREMENT_COLUMNS, read_increments

__all__ = ["META_KEY", "TEMPERATURE_COLUMN", "import_log", "read_log_table", "read_log_temperature",
           "write_log_table", "summary_lines"]

#: The Parquet key-value metadata key holding the provenance (JSON).
META_KEY = "sins_sim"
#: The optional temperature column of an increments table (deg C, the unit's temperature over each interval).
TEMPERATURE_COLUMN = "temperature_c"
_PARQUET_SUFFIXES = (".parquet", ".pq")


def write_log_table(path, t_s, dtheta, dv, meta: dict, temperature_c=None) -> None:
    """Write an increments table (Parquet, columns :data:`INCREMENT_COLUMNS`, and ``temperature_c`` (deg C) when
    given) with ``meta`` as JSON under :data:`META_KEY` in its key-value metadata."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    arrays = [np.asarray(t_s, dtype=np.float64)] + [np.asarray(a, dtype=np.float64)[:, i]
                                                      for a in (dtheta, dv) for i in range(3)]
    columns = dict(zip(INCREMENT_COLUMNS, arrays))
    if temperature_c is not None:
        columns[TEMPERATURE_COLUMN] = np.asarray(temperature_c, dtype=np.float64)
    table = pa.table(columns)
    table = table.replace_schema_metadata({META_KEY: json.dumps(meta, allow_nan=False)})
    pq.write_table(table, path)


def read_log_table(path) -> tuple:
    """``(t_s, dtheta, dv, meta)`` of an increments file; ``meta`` is the provenance :func:`import_log` stored
    (``{}`` for a plain increments file, CSV or Parquet, without it).

    Raises
    ------
    ConfigError
        As :func:`~sins_sim.jobs.navigate.read_increments`, and for metadata that is not JSON.
    """
    t, dth, dv = read_increments(path)
    p = Path(path)
    meta: dict = {}
    if p.suffix.lower() in _PARQUET_SUFFIXES:
        import pyarrow.parquet as pq

        raw = (pq.read_schema(p).metadata or {}).get(META_KEY.encode())
        if raw is not None:
            try:
                meta = json.loads(raw.decode("utf-8"))
            except (UnicodeDecodeError, ValueError) as exc:
                raise ConfigError(f"{p}: metadata key {META_KEY!r} is not JSON ({exc})") from None
    return t, dth, dv, meta


def read_log_temperature(path):
    """The ``temperature_c`` column of an increments file (deg C, one per interval), or None where it has none.

    Raises
    ------
    ConfigError
        A cell that is not a finite number.
    """
    import pandas as pd

    p = Path(path)
    if p.suffix.lower() in _PARQUET_SUFFIXES:
        import pyarrow.parquet as pq

        if TEMPERATURE_COLUMN not in pq.read_schema(p).names:
            return None
        x = pq.read_table(p, columns=[TEMPERATURE_COLUMN]).column(0).to_numpy()
    else:
        head = pd.read_csv(p, comment="#", nrows=0)
        if TEMPERATURE_COLUMN not in [str(c).strip() for c in head.columns]:
            return None
        df = pd.read_csv(p, comment="#", skip_blank_lines=True, float_precision="round_trip")
        df.columns = [str(c).strip() for c in df.columns]
        x = pd.to_numeric(df[TEMPERATURE_COLUMN], errors="coerce").to_numpy(dtype=np.float64)
    x = np.asarray(x, dtype=np.float64)
    bad = np.flatnonzero(~np.isfinite(x))
    if bad.size:
        raise ConfigError(f"{p}: {TEMPERATURE_COLUMN}: row {int(bad[0]) + 1} is not a finite number")
    return x


def _deg(x):
    return None if x is None else math.degrees(x)


def import_log(log, describe, out, *, force: bool = False) -> dict:
    """``sins-sim import-log``: read ``log`` as ``describe`` says, write the increments table ``out``.

    Parameters
    ----------
    log : path
        The unit's log (text, CSV or Parquet, as the description says).
    describe : path or mapping
        The log description (:func:`sins_sim.config.log.load_log_description`).
    out : path
        The Parquet file to write (``.parquet`` or ``.pq``); an existing one is replaced only with ``force``,
        and only once the new one is complete.

    Returns
    -------
    dict
        The metadata written (``report``: the reader's report).

    Raises
    ------
    ConfigError, LogFileError
        One line naming the flag, the file, the line or the key.
    """
    from sins_sim._version import __version__
    from sins_sim.config.log import load_log_description
    from sins_sim.io.unitlog import read_unit_log
    from sins_sim.jobs.manifest import sha256_file
    from sins_sim.jobs.output import atomic_output_file

    target = Path(out)
    if target.suffix.lower() not in _PARQUET_SUFFIXES:
        raise ConfigError(f"--out: must end in .parquet or .pq (the provenance lives in the Parquet metadata), "
                          f"got {str(out)!r}")
    if (target.exists() or target.is_symlink()) and not force:
        raise ConfigError(f"--out: {target} already exists; pass --force to replace it (once the new file is "
                          "complete) or choose another file")
    if Path(log).resolve() == target.resolve():
        raise ConfigError(f"--out: {target} is the log itself")
    desc = load_log_description(describe)
    res = read_unit_log(log, desc.layout)
    rep = res.report
    meta = {
        "format": "sins-sim increments from a unit's log",
        "sins_sim_version": __version__,
        "source": {"path": str(log), "sha256": sha256_file(log)},
        "description": {"source": desc.source, **desc.resolved},
        "site": rep["site"],
        "initial_velocity_ned_m_s": rep["initial_velocity_ned_m_s"],
        "report": rep,
    }
    with atomic_output_file(target, "--out") as tmp:
        write_log_table(tmp, res.t_s, res.dtheta, res.dv, meta, temperature_c=res.temperature_c)
    return meta


def summary_lines(meta: dict, out) -> list:
    """The command's short summary: rows, rate, duration, duplicates and gaps, site, the file written."""
    rep = meta["report"]
    lines = [f"read {rep['file']}: {rep['rows_read']} rows -> {rep['rows']} intervals at {rep['rate_hz']:.9g} Hz "
             f"({rep['duration_s']:.6g} s, {rep['start_s']:.6g} to {rep['end_s']:.6g} s)"]
    gaps = rep["gaps"]
    filled = len(rep["filled_intervals"])
    lines.append(f"duplicates dropped: {rep['duplicates_dropped']}; gaps: "
                 + (f"{len(gaps)}, {filled} interval(s) filled with the mean of their neighbours (listed in the "
                    "metadata)" if gaps else "none")
                 + ("" if "note" not in rep else f" ({rep['note']})"))
    site = rep["site"]
    if site:
        parts = [f"lat {_deg(site['lat_rad']):.8g} deg" if "lat_rad" in site else None,
                 f"lon {_deg(site['lon_rad']):.8g} deg" if "lon_rad" in site else None,
                 f"height {site['height_m']:.6g} m" if "height_m" in site else None]
        lines.append("site: " + ", ".join(p for p in parts if p))
    else:
        lines.append("site: not given")
    rest = rep.get("rest_check") or {}
    if rest.get("latitude_deg") is not None:
        verdict = " (contradicts the site's)" if rest.get("agrees_with_site") is False else ""
        lines.append(f"at rest for the first {rest['window_s']:g} s: the gyros' Earth rate about the vertical "
                     f"implies latitude {rest['latitude_deg']:.4g} deg{verdict}")
    v = rep["initial_velocity_ned_m_s"]
    if any(v):
        lines.append(f"initial velocity N, E, D: {v[0]:.6g}, {v[1]:.6g}, {v[2]:.6g} m/s")
    lines.append(f"wrote {out}: {', '.join(INCREMENT_COLUMNS)} (body axes forward-right-down); provenance in its "
                 f"metadata key {META_KEY!r}")
    return lines
