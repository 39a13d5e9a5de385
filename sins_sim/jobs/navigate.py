"""``sins-sim navigate``: navigate angle and velocity increments from elsewhere against a trajectory's truth.

Increments from another simulator or a logged IMU go through sins-sim's strapdown navigator and come
out with the metrics of ``sins-sim run`` (:func:`sins_sim.jobs.run.scenario_metrics`: position,
velocity and attitude errors, the psi angle and the attitude drift per NED axis, the gyro drift per
body axis, the Allan terms where the vehicle rests).

The increments file (CSV with one header row and optional ``#`` comment lines before it, or Parquet)
has the columns :data:`INCREMENT_COLUMNS`:

- ``time_s``: end of each increment's interval, on the trajectory file's time axis (its ``time_s``
  column), uniformly spaced; the rate is taken from it; navigation starts one period before the
  first row, aligned to the truth there;
- ``dtheta_x_rad, dtheta_y_rad, dtheta_z_rad``: angle increments, body axes (x forward, y right,
  z down: the trajectory's vehicle frame), rad, raw (not coning-compensated);
- ``dv_x_m_s, dv_y_m_s, dv_z_m_s``: velocity increments (specific force integrated), body axes, m/s,
  raw (not sculling-compensated).

API: :func:`navigate_increments` (arrays and a trajectory in, metrics out), :func:`read_increments`,
:func:`navigate_file` (what the command runs).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from sins_sim.config.errors import ConfigError

__all__ = ["INCREMENT_COLUMNS", "read_increments", "write_increments", "navigate_increments", "navigate_file"]

#: The columns of an increments file, in this order when sins-sim writes one.
INCREMENT_COLUMNS = ("time_s", "dtheta_x_rad", "dtheta_y_rad", "dtheta_z_rad", "dv_x_m_s", "dv_y_m_s", "dv_z_m_s")


def read_increments(path) -> tuple:
    """``(t_s, dtheta, dv)`` from an increments file (CSV or Parquet; columns :data:`INCREMENT_COLUMNS`).

    Raises
    ------
    ConfigError
        One line naming the file and the column or row: unreadable, a missing or unknown column, a cell
        that is not a finite number.
    """
    import pandas as pd

    p = Path(path)
    if not p.is_file():
        raise ConfigError(f"{p}: cannot read: no such file")
    try:
        if p.suffix.lower() in (".parquet", ".pq"):
            df = pd.read_parquet(p)
        else:
            df = pd.read_csv(p, comment="#", skip_blank_lines=True)
    except pd.errors.EmptyDataError:
        raise ConfigError(f"{p}: line 1: no header row, the file is empty (needs the columns "
                          f"{', '.join(INCREMENT_COLUMNS)})") from None
    except Exception as exc:  # noqa: BLE001 - any reader failure is the file's fault: one line
        raise ConfigError(f"{p}: cannot read: {' '.join(str(exc).split())}") from None
    cols = [str(c).strip() for c in df.columns]
    missing = [c for c in INCREMENT_COLUMNS if c not in cols]
    if missing:
        raise ConfigError(f"{p}: column {missing[0]}: missing{' (with ' + ', '.join(missing[1:]) + ')' if missing[1:] else ''}"
                          f"; the file needs {', '.join(INCREMENT_COLUMNS)}")
    extra = [c for c in cols if c not in INCREMENT_COLUMNS]
    if extra:
        import difflib

        close = difflib.get_close_matches(extra[0], INCREMENT_COLUMNS, n=1)
        raise ConfigError(f"{p}: column {extra[0]}: unknown{'; did you mean ' + repr(close[0]) + '?' if close else ''} "
                          f"(allowed: {', '.join(INCREMENT_COLUMNS)})")
    df.columns = cols
    data = {}
    for c in INCREMENT_COLUMNS:
        x = pd.to_numeric(df[c], errors="coerce").to_numpy(dtype=np.float64)
        bad = np.flatnonzero(~np.isfinite(x))
        if bad.size:
            raise ConfigError(f"{p}: {c}: row {int(bad[0]) + 1} is not a finite number ({df[c].iloc[bad[0]]!r})")
        data[c] = x
    return (data["time_s"], np.stack([data[c] for c in INCREMENT_COLUMNS[1:4]], axis=1),
            np.stack([data[c] for c in INCREMENT_COLUMNS[4:7]], axis=1))


def write_increments(path, t_s, dtheta, dv) -> None:
    """Write an increments file (CSV, or Parquet for ``.parquet``/``.pq``) that :func:`read_increments` reads back."""
    import pandas as pd

    arr = np.column_stack([np.asarray(t_s, dtype=np.float64), np.asarray(dtheta), np.asarray(dv)])
    df = pd.DataFrame(arr, columns=list(INCREMENT_COLUMNS))
    p = Path(path)
    if p.suffix.lower() in (".parquet", ".pq"):
        df.to_parquet(p, index=False)
    else:
        df.to_csv(p, index=False, float_format="%.17g")


class _Context:
    """What :func:`sins_sim.jobs.run.scenario_metrics` reads from a scenario: the site latitude and the events."""

    def __init__(self, lat_rad: float):
        self.site = {"lat_rad": float(lat_rad)}
        self.events = ()


def navigate_increments(t_s, dtheta, dv, truth, *, name: str = "external", coning: str = "two_sample",
                        sculling: str = "two_sample", vertical: str = "height_aid",
                        height_aid_tau_s: float = 100.0) -> dict:
    """Navigate increments against a truth; return the metrics of ``sins-sim run`` for them.

    Parameters
    ----------
    t_s, dtheta, dv, truth, coning, sculling, vertical, height_aid_tau_s
        As :func:`sins_sim.simulation.external.navigate_increments` (times on the truth's own axis:
        seconds since its first sample).
    name : str
        The key of the result in ``filters``.

    Returns
    -------
    dict
        ``{"filters": {name: metrics}, "navigation": {...settings, start_s, end_s, rate_hz}}``; the
        metrics are those of a filter in ``metrics.json`` of ``sins-sim run``.

    Examples
    --------
    >>> from sins_sim.models.motion import Stationary, Trajectory
    >>> from sins_sim.simulation.external import ideal_increments
    >>> truth = Trajectory(0.7, 0.2, 100.0, 0.0, 0.0, [Stationary(120.0)])
    >>> t = 0.01 * np.arange(1, 6001)
    >>> dth, dv = ideal_increments(truth, t)
    >>> m = navigate_increments(t, dth, dv, truth)["filters"]["external"]
    >>> m["horizontal_position_error_m"]["final"] < 1e-6
    True
    """
    from sins_sim.jobs.run import scenario_metrics
    from sins_sim.simulation.external import navigate_increments as _navigate

    res = _navigate(t_s, dtheta, dv, truth, name=name, coning=coning, sculling=sculling, vertical=vertical,
                    height_aid_tau_s=height_aid_tau_s)
    lat0 = float(res.truth_series["lat_rad"][0]) if res.truth_series["lat_rad"].size else 0.0
    return {"filters": scenario_metrics(res, _Context(lat0)),
            "navigation": {**res.settings, "start_s": res.nav_start_s, "end_s": res.duration_s}}


def _in_file_terms(message: str) -> str:
    """A message of :func:`sins_sim.simulation.external.navigate_increments` in the file's words: ``t_s`` is the
    column ``time_s``, ``dtheta[i, j]`` and ``dv[i, j]`` are row ``i + 1`` of ``dtheta_<axis>_rad`` and
    ``dv_<axis>_m_s``."""
    import re

    m = re.match(r"(dtheta|dv)\[(\d+), (\d)\]: (.*)$", message)
    if m:
        col = INCREMENT_COLUMNS[(1 if m.group(1) == "dtheta" else 4) + int(m.group(3))]
        return f"{col}: row {int(m.group(2)) + 1}: {m.group(4)}"
    if message.startswith("t_s: "):  # its rows are indices from 0; the file's data rows count from 1
        return "time_s: " + re.sub(r"\brow (\d+)", lambda r: f"row {int(r.group(1)) + 1}", message[5:])
    return message


def navigate_file(increments, truth_file, out_dir, *, name: str = "external", coning: str = "two_sample",
                  sculling: str = "two_sample", vertical: str = "height_aid", height_aid_tau_s: float = 100.0,
                  force: bool = False, manifest=None) -> dict:
    """``sins-sim navigate``: read the increments and the trajectory file, navigate, write ``metrics.json``
    and ``manifest.json`` (the command, versions, the two inputs' hashes; ``manifest`` from the CLI).

    The increments' ``time_s`` is on the trajectory file's time axis (its own ``time_s`` column).
    Returns the metrics written.
    """
    from sins_sim.io import read_trajectory
    from sins_sim.jobs.manifest import Manifest, result_dir
    from sins_sim.jobs.output import atomic_write_text
    from sins_sim.jobs.run import _json_default
    from sins_sim.models.motion import SampledTrajectory
    from sins_sim.models.motion.trajectory import velocity_check_in_file_terms

    t, dth, dv = read_increments(increments)
    try:
        data = read_trajectory(truth_file)
        truth = SampledTrajectory.from_data(data)
    except ValueError as exc:
        msg = velocity_check_in_file_terms(" ".join(str(exc).split()), str(truth_file), "the tolerance (m/s)")
        raise ConfigError(f"--truth: {msg}") from None
    offset = truth.time_offset_s
    try:
        metrics = navigate_increments(t - offset, dth, dv, truth, name=name, coning=coning, sculling=sculling,
                                      vertical=vertical, height_aid_tau_s=height_aid_tau_s)
    except ValueError as exc:
        raise ConfigError(f"{increments}: {_in_file_terms(' '.join(str(exc).split()))}") from None
    nav = metrics["navigation"]
    nav["start_s"] += offset  # back on the files' time axis
    nav["end_s"] += offset
    metrics = {"increments": str(increments), "truth": str(truth_file), **metrics}
    if manifest is None:
        manifest = Manifest("navigate", settings={"name": name, "coning": coning, "sculling": sculling,
                                                  "vertical": vertical, "height_aid_tau_s": height_aid_tau_s})
    manifest.add_input("increments", increments)
    manifest.add_input("truth", truth_file)
    with result_dir(out_dir, manifest, inputs=(increments, truth_file), force=force) as tmp:
        atomic_write_text(Path(tmp) / "metrics.json", json.dumps(metrics, indent=2, default=_json_default) + "\n")
    return metrics
