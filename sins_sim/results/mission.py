"""A mission as a Python object (:func:`sins_sim.run` in a notebook, :func:`sins_sim.load` of a result folder).

``sins-sim run`` writes a folder; a notebook wants the same run as an object it can show, tabulate
and plot without a file in between::

    import sins_sim
    r = sins_sim.run("scenarios/nav-static.yaml", duration_s=60)   # or a dict, or a Scenario
    r                                  # scenario, duration, per filter the headline errors
    frames = r.to_pandas()             # time-indexed tables, unit-suffixed columns
    fig = r.plot("navigation_error")   # the CLI's figure, returned instead of written
    r.save("out/static")               # exactly what `sins-sim run --out out/static` writes
    r2 = sins_sim.load("out/static")

:class:`MissionResult` holds the scenario, the metrics (the content of ``metrics.json``) and the
engine's :class:`~sins_sim.simulation.sins.SinsResult`. Its tables come from the same stored series
as ``timeseries.npz`` (block means with their min/max envelope over each stored interval, never a
decimated sample) and its figures from the same functions as the CLI's
(:func:`sins_sim.plots.navigation.run_figure`).

Units: the tables and the Dataset are in engineering units, each column's unit in its name
(``_m``, ``_m_s``, ``_arcsec``, ``_deg``) and each variable's in its ``units`` attribute; the
:attr:`MissionResult.result` underneath is SI and rad, like the engine.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from sins_sim.config.errors import ConfigError
from sins_sim.units import ARCSEC

__all__ = ["MissionResult", "StoredRun", "FIGURE_KINDS", "SERIES_COLUMNS"]

#: The figures :meth:`MissionResult.plot` draws (the CLI's ``<kind>.png``, ``plots.navigation.RUN_FIGURES``; the
#: block's two only with an IMU ``block:``).
FIGURE_KINDS = ("navigation_error", "attitude_error", "trajectory", "gyro_error_spectrum", "allan", "block_spectrum",
                "block_coning")
_NED = ("north", "east", "down")
_BODY = ("x", "y", "z")
_STATS = ("", "_min", "_max")

#: Stored series (``timeseries.npz`` key after ``<filter>__``) -> (column stems, unit, conversion, what it is).
#: A column is ``<stem><stat>_<unit>``, stat ``""`` (the mean over the stored interval), ``_min`` or ``_max``.
SERIES_COLUMNS = {
    "north_m": (("north",), "m", None, "north position error (computed minus true)"),
    "east_m": (("east",), "m", None, "east position error (computed minus true)"),
    "horizontal_m": (("horizontal",), "m", None, "horizontal position error (its magnitude)"),
    "vertical_m": (("vertical",), "m", None, "height error, up (computed minus true)"),
    "velocity_ned_m_s": (("vn", "ve", "vd"), "m_s", None, "velocity error, NED (computed minus true)"),
    "attitude_ned_rad": (tuple(f"phi_{a}" for a in _NED), "arcsec", "arcsec",
                         "attitude error phi per NED axis (rotation vector of q_est x q_true*)"),
    "attitude_free_ned_rad": (tuple(f"phi_free_{a}" for a in _NED), "arcsec", "arcsec",
                              "free attitude error: the filter's gyro-angle error accumulated in NED"),
    "lat_rad": (("lat",), "deg", "deg", "the filter's solution: latitude"),
    "lon_rad": (("lon",), "deg", "deg", "the filter's solution: longitude"),
}
#: The truth path's stored series -> (column, conversion).
TRUTH_COLUMNS = {"lat_rad": ("lat_deg", "deg"), "lon_rad": ("lon_deg", "deg"), "h_m": ("h_m", None)}
#: The aided run's error columns (:meth:`MissionResult.to_pandas` ``aided_<filter>``; ``sigma_`` + each: the filter's
#: 1-sigma), in the order of the filter's states.
_AIDED_COLUMNS = ("north_m", "east_m", "down_m", "vn_m_s", "ve_m_s", "vd_m_s", "psi_north_arcsec", "psi_east_arcsec",
                  "psi_down_arcsec")
#: Keys of :meth:`MissionResult.to_pandas` besides the filters'.
RESERVED_FRAMES = ("summary", "truth", "gyro_error")


def _convert(x, how):
    """SI to the column's unit: rad -> arcsec or deg (the same operations as the tests' reference)."""
    x = np.asarray(x, dtype=float)
    if how == "arcsec":
        return x / ARCSEC
    if how == "deg":
        return np.degrees(x)
    return x


class StoredRun:
    """What a run folder keeps of a :class:`~sins_sim.simulation.sins.SinsResult` (``timeseries.npz`` and
    ``metrics.json``): enough for the tables and for every figure but the Allan one.

    Attributes
    ----------
    series, truth_series, spectra : dict
        As in :class:`~sins_sim.simulation.sins.SinsResult` (SI, rad).
    filters : tuple of str
    filter_rate_hz, duration_s, nav_start_s : float
    drives : list of dict
        From ``metrics.json`` (the measured drives).
    allan : dict
        Always empty: the Allan curves are not stored, only their readings (in ``metrics.json``).
    block : dict or None
        With an IMU ``block:``, the block's rotation record (``block_t_s``, ``block_theta_rad``) and its isolator
        modes (``metrics.json`` ``block``), as ``SinsResult.block``.
    """

    def __init__(self, arrays: dict, metrics: dict):
        self.series, self.truth_series, self.spectra = {}, {}, {}
        for key, val in arrays.items():
            if "__" in key:
                name, field = key.split("__", 1)
                self.series.setdefault(name, {})[field] = val
            elif key.startswith("truth_"):
                self.truth_series[key[len("truth_"):]] = val
            elif key.startswith("gyro_error_"):
                self.spectra[key[len("gyro_error_"):]] = val
        self.aided = {}
        for key, val in arrays.items():  # the aided runs' epochs (timeseries.npz aided.<filter>.<field>)
            if key.startswith("aided."):
                _, name, fld = key.split(".", 2)
                self.aided.setdefault(name, {})[fld] = val
        blk = metrics.get("block")
        self.block = None
        if blk is not None and "block_theta_rad" in arrays:  # SinsResult.block, from the npz and metrics.json
            self.block = {"t_s": arrays["block_t_s"], "theta_rad": arrays["block_theta_rad"],
                          "rate_hz": float(metrics["navigation"]["update_rate_hz"]) * int(metrics["navigation"]["n_sub"]),
                          "isolator_modes_hz": list(blk["isolator_modes_hz"]),
                          "isolator_damping": list(blk["isolator_damping"])}
        nav = metrics["navigation"]
        self.filters = tuple(metrics["filters"])
        self.filter_rate_hz = float(nav["update_rate_hz"]) * int(nav["n_sub"])
        self.duration_s = float(metrics["duration_s"])
        self.nav_start_s = float(nav["start_s"])
        self.drives = list(metrics["drives"])
        self.diverged = dict(metrics.get("diverged") or {})
        self.allan = {}


class MissionResult:
    """One mission: the scenario, its metrics and the engine's result, with tables, figures and a folder.

    Made by :func:`sins_sim.run` (in memory) or :func:`sins_sim.load` (from a result folder).

    Attributes
    ----------
    scenario : Scenario or None
        The validated scenario (:func:`sins_sim.config.scenario.load_scenario`); after :func:`load`, the one of
        the folder's ``inputs/scenario.yaml`` (None if that no longer validates).
    metrics : dict
        The content of ``metrics.json`` (:data:`sins_sim.jobs.run.DEFINITIONS` says what each figure is).
    result : SinsResult or StoredRun
        The engine's result (SI, rad); after :func:`load` a :class:`StoredRun`.
    manifest : dict or None
        After :func:`load`, the folder's ``manifest.json``; None for a run not yet saved.
    folder : Path or None
        Where the result was saved or loaded from.

    Notes
    -----
    ``origin`` is the command that made the run in memory (:class:`sins_sim.jobs.notebook.RunOrigin`):
    it knows the run's inputs and writes its folder, so :meth:`configuration` and :meth:`save` hand off
    to it and this room never imports a command. A result loaded from a folder has none.
    """

    def __init__(self, scenario, metrics: dict, result, *, origin=None, folder=None):
        self.scenario = scenario
        self.metrics = metrics
        self.result = result
        self._origin = origin  # configuration(base_dir) -> dict; save(folder, force, mission) -> manifest
        self.manifest = None
        self.folder = Path(folder) if folder is not None else None

    # --- what it is --------------------------------------------------------------------------------------------
    @property
    def name(self) -> str:
        """The scenario's name."""
        return self.metrics["scenario"]

    @property
    def duration_s(self) -> float:
        """The mission length (s)."""
        return float(self.metrics["duration_s"])

    @property
    def seed(self) -> int:
        """The seed every random stream of the run derives from."""
        return int(self.metrics["seed"])

    @property
    def filters(self) -> tuple:
        """The filters compared, in the scenario's order."""
        return tuple(self.metrics["filters"])

    @property
    def figures(self) -> list:
        """The figure kinds this result has data for (:meth:`plot`)."""
        from sins_sim.plots.navigation import available_figures

        return available_figures(self.result, self.metrics)

    def _headline(self):
        """Per filter: (name, final horizontal error m, phi RMS N/E/D arcsec, status)."""
        rows = []
        for name, m in self.metrics["filters"].items():
            if "horizontal_position_error_m" not in m:
                rows.append((name, None, None, m["status"]))
                continue
            rms = m["attitude_error_arcsec"]["rms"]
            rows.append((name, m["horizontal_position_error_m"]["final"], [rms[a] for a in _NED], m["status"]))
        return rows

    def __repr__(self) -> str:
        head = (f"MissionResult: scenario '{self.name}', {self.duration_s:g} s, seed {self.seed}, "
                f"IMU '{self.metrics['imu']}'")
        width = max([len("filter")] + [len(n) for n in self.filters])
        lines = [head, f"  {'filter':<{width}}  horizontal final (m)  {'phi RMS N, E, D (arcsec)':<30}  status"]
        for name, hor, rms, status in self._headline():
            h = "" if hor is None else f"{hor:.4g}"
            r = "" if rms is None else ", ".join(f"{x:.3g}" for x in rms)
            lines.append(f"  {name:<{width}}  {h:>20}  {r:<30}  {status}")
        if self.metrics.get("warnings"):
            lines.append(f"  {len(self.metrics['warnings'])} warning(s): .metrics['warnings']")
        return "\n".join(lines)

    def _repr_html_(self) -> str:
        from html import escape

        rows = "".join(
            f"<tr><td>{escape(n)}</td><td>{'' if h is None else f'{h:.4g}'}</td>"
            f"<td>{'' if r is None else ', '.join(f'{x:.3g}' for x in r)}</td><td>{escape(s)}</td></tr>"
            for n, h, r, s in self._headline())
        warn = ""
        if self.metrics.get("warnings"):
            warn = "<ul>" + "".join(f"<li>{escape(w)}</li>" for w in self.metrics["warnings"]) + "</ul>"
        return (f"<div><b>MissionResult</b>: scenario <code>{escape(self.name)}</code>, {self.duration_s:g} s, "
                f"seed {self.seed}, IMU <code>{escape(str(self.metrics['imu']))}</code>"
                "<table><thead><tr><th>filter</th><th>horizontal final (m)</th><th>phi RMS N, E, D (arcsec)</th>"
                f"<th>status</th></tr></thead><tbody>{rows}</tbody></table>{warn}</div>")

    # --- tables ------------------------------------------------------------------------------------------------
    def summary(self):
        """One row per filter (index ``filter``): the headline figures of ``metrics.json``.

        Columns: ``status``, ``horizontal_final_m``, ``horizontal_max_m``, ``north_final_m``,
        ``east_final_m``, ``vertical_final_m``, ``velocity_final_m_s``, ``phi_final_<axis>_arcsec`` and
        ``phi_rms_<axis>_arcsec`` (NED), ``cep_rate_nmi_h`` and ``excess_over_ideal_m`` (NaN where
        ``metrics.json`` has null or the filter has no data).
        """
        import pandas as pd

        rows = {}
        for name, m in self.metrics["filters"].items():
            row = {"status": m["status"]}
            if "horizontal_position_error_m" in m:
                hp, att = m["horizontal_position_error_m"], m["attitude_error_arcsec"]
                exc = m.get("excess_over_ideal")
                row.update(horizontal_final_m=hp["final"], horizontal_max_m=hp["max"], north_final_m=hp["final_north"],
                           east_final_m=hp["final_east"], vertical_final_m=m["vertical_position_error_m"]["final"],
                           velocity_final_m_s=m["velocity_error_m_s"]["final"],
                           **{f"phi_final_{a}_arcsec": att["final"][a] for a in _NED},
                           **{f"phi_rms_{a}_arcsec": att["rms"][a] for a in _NED},
                           cep_rate_nmi_h=m["cep_rate_nmi_h"],
                           excess_over_ideal_m=exc["horizontal_position_error_final_m"] if exc else None)
            rows[name] = row
        df = pd.DataFrame.from_dict(rows, orient="index")
        df.index.name = "filter"
        num = [c for c in df.columns if c != "status"]
        df[num] = df[num].astype(float)
        return df

    def _series(self):
        if not getattr(self.result, "truth_series", None) or not self.result.truth_series.get("t_s", np.zeros(0)).size:
            raise ValueError(f"{self.name}: this result has no stored series (outputs.timeseries was off when it "
                             "was saved, or the run has no navigation)")
        return self.result

    def _aided(self) -> dict:
        """Per filter ``(t_s, errors (K, 9), sigma (K, 15))`` of the aided run (empty without aiding)."""
        out = {}
        for name, a in (getattr(self.result, "aided", None) or {}).items():
            if name == "fixes":
                continue
            if "result" in a:   # in memory: SinsResult.aided
                out[name] = (a["result"].t_s, a["errors"], a["result"].sigma)
            else:               # from a folder: StoredRun.aided
                out[name] = (a["t_s"], a["errors"], a["sigma"])
        return out

    def to_pandas(self) -> dict:
        """The run as pandas tables: a dict of DataFrames.

        Returns
        -------
        dict of str -> pandas.DataFrame
            ``"summary"``
                :meth:`summary`: one row per filter, the headline figures of ``metrics.json``.
            ``"truth"``
                Index ``t_s`` (the stored rate); ``lat_deg``, ``lon_deg``, ``h_m``: the true path.
            ``<filter>`` (one per filter with a navigation solution, :attr:`filters` order)
                Index ``t_s``: the centre of each stored interval (from the navigation start; each
                filter has its own, shifted by its delay, so the filters are separate tables).
                Columns, each as the mean over the interval and its ``_min`` / ``_max`` envelope
                (``north_m``, ``north_min_m``, ``north_max_m``, ...): ``north_m``, ``east_m``,
                ``horizontal_m``, ``vertical_m`` (up) position errors; ``vn_m_s``, ``ve_m_s``,
                ``vd_m_s`` velocity errors; ``phi_north_arcsec``, ``phi_east_arcsec``,
                ``phi_down_arcsec`` attitude error phi; ``phi_free_*_arcsec`` the free attitude error;
                ``lat_deg``, ``lon_deg`` the filter's solution (:data:`SERIES_COLUMNS`).
            ``"gyro_error"``
                Index ``t_s`` at the full filter rate over ``navigation.spectrum_s``; columns
                ``<filter>_<x|y|z>_arcsec``: each filter's gyro-angle error (output minus truth) per
                body axis. Absent when the run stored none.
            ``aided_<filter>`` (with ``aiding:``)
                Index ``t_s``: the aided filter's epochs (every update, every second, the outage growth's times);
                columns ``north_m``, ``east_m``, ``down_m``, ``vn_m_s``, ``ve_m_s``, ``vd_m_s``,
                ``psi_north_arcsec``, ``psi_east_arcsec``, ``psi_down_arcsec``: the aided solution's error against
                the truth, and ``sigma_`` + each: the filter's own 1-sigma of that state.

        Notes
        -----
        Every value is the stored one of ``timeseries.npz`` converted to the column's unit (rad to
        arcsec by ``/ ARCSEC``, to deg by ``numpy.degrees``); nothing is resampled or interpolated.
        """
        import pandas as pd

        res = self._series()
        out = {"summary": self.summary()}
        ts = res.truth_series
        out["truth"] = pd.DataFrame({col: _convert(ts[k], how) for k, (col, how) in TRUTH_COLUMNS.items()},
                                    index=pd.Index(np.asarray(ts["t_s"], dtype=float), name="t_s"))
        for name, ser in res.series.items():
            if name in RESERVED_FRAMES:
                raise ValueError(f"a filter named {name!r} clashes with the table of that name")
            cols = {}
            for key, (stems, unit, how, _) in SERIES_COLUMNS.items():
                for stat in _STATS:
                    a = _convert(ser[key + stat], how)
                    a = a.reshape(a.shape[0], -1)
                    for i, stem in enumerate(stems):
                        cols[f"{stem}{stat}_{unit}"] = a[:, i]
            out[name] = pd.DataFrame(cols, index=pd.Index(np.asarray(ser["t_s"], dtype=float), name="t_s"))
        sp = res.spectra or {}
        if sp.get("t") is not None and np.asarray(sp["t"]).size:
            cols = {}
            for name, e in sp.items():
                if name == "t":
                    continue
                e = _convert(e, "arcsec")
                for i, ax in enumerate(_BODY):
                    cols[f"{name}_{ax}_arcsec"] = e[:, i]
            out["gyro_error"] = pd.DataFrame(cols, index=pd.Index(np.asarray(sp["t"], dtype=float), name="t_s"))
        for name, (t, err, sig) in self._aided().items():
            cols = {}
            for i, col in enumerate(_AIDED_COLUMNS):
                conv = "arcsec" if col.endswith("arcsec") else None
                cols[col] = _convert(err[:, i], conv)
                cols["sigma_" + col] = _convert(sig[:, i], conv)
            out[f"aided_{name}"] = pd.DataFrame(cols, index=pd.Index(np.asarray(t, dtype=float), name="t_s"))
        return out

    def configuration(self) -> dict:
        """The scenario and the IMU as run, every default written out (``run.scenario`` and ``run.imu`` of
        the manifest; :func:`sins_sim.jobs.manifest.resolve_run_inputs`)."""
        if self.manifest is not None and "run" in self.manifest:
            return {"scenario": self.manifest["run"]["scenario"], "imu": self.manifest["run"]["imu"]}
        if self._origin is None:
            raise ConfigError(f"{self.name}: the folder this result was loaded from has no run inputs in its "
                              "manifest.json")
        return self._origin.configuration(getattr(self.scenario, "base_dir", None))

    def to_xarray(self):
        """The run as one :class:`xarray.Dataset`.

        Dimensions: ``time`` (the filters' stored intervals; the union of the filters' times, NaN where a
        filter has no sample), ``filter``, ``axis`` (north, east, down), ``time_truth`` (the truth's
        stored rate), and, when the run stored gyro-angle errors, ``time_gyro`` (the full filter rate)
        and ``gyro_axis`` (x, y, z).

        Variables, each with ``units`` and ``long_name``: per :data:`SERIES_COLUMNS` entry a variable named
        by its stem without the axis (``north``, ``east``, ``horizontal``, ``vertical``, ``velocity``,
        ``phi``, ``phi_free``, ``lat``, ``lon``), on ``(time, filter)`` or ``(time, filter, axis)``, with
        ``<name>_min`` and ``<name>_max`` the envelopes; ``truth_lat``, ``truth_lon``, ``truth_h`` on
        ``time_truth``; ``gyro_error`` on ``(time_gyro, filter, gyro_axis)``; and the headline figures of
        ``metrics.json`` on ``filter`` (``horizontal_final``, ``horizontal_peak`` (its ``max``: over every
        navigation update, not only the stored means), ``vertical_final``,
        ``velocity_final``, ``cep_rate``, ``status``) and ``(filter, axis)`` (``phi_final``, ``phi_rms``).

        With ``aiding:``, ``aided_error`` and ``aided_sigma`` on ``(filter, time_aided, aided_state)``: the aided
        solution's error and the filter's 1-sigma, the states named with their units as in :meth:`to_pandas`'s
        ``aided_<filter>`` columns.

        Attributes: ``scenario``, ``seed``, ``duration_s``, ``sins_sim_version`` and ``configuration``
        (JSON text of :meth:`configuration`).
        """
        import xarray as xr

        from sins_sim._version import __version__

        res = self._series()
        per_filter = []
        names = [n for n in res.series]
        for name in names:
            ser = res.series[name]
            data = {}
            for key, (stems, unit, how, what) in SERIES_COLUMNS.items():
                var = {"velocity_ned_m_s": "velocity", "attitude_ned_rad": "phi",
                       "attitude_free_ned_rad": "phi_free"}.get(key, stems[0])
                for stat in _STATS:
                    a = _convert(ser[key + stat], how)
                    dims = ("time", "axis") if a.ndim == 2 else ("time",)
                    data[var + stat] = (dims, a, {"units": unit.replace("_", "/"),
                                                  "long_name": what + {"": " (mean over the stored interval)",
                                                                       "_min": " (minimum within the interval)",
                                                                       "_max": " (maximum within the interval)"}[stat]})
            per_filter.append(xr.Dataset(data, coords={"time": np.asarray(ser["t_s"], dtype=float), "axis": list(_NED)}))
        ds = xr.Dataset()
        if per_filter:
            ds = xr.concat(per_filter, dim="filter", join="outer").assign_coords(filter=np.array(names, dtype=str))
        ts = res.truth_series
        for k, (col, how) in TRUTH_COLUMNS.items():
            stem, unit = col.split("_", 1)
            ds["truth_" + stem] = xr.DataArray(_convert(ts[k], how), dims=("time_truth",),
                                               attrs={"units": unit, "long_name": f"true {stem}"})
        ds = ds.assign_coords(time_truth=np.asarray(ts["t_s"], dtype=float))
        sp = res.spectra or {}
        gyro_names = [n for n in sp if n != "t"]
        if gyro_names and np.asarray(sp["t"]).size:
            g = np.stack([_convert(sp[n], "arcsec") for n in gyro_names], axis=1)
            gyro = xr.DataArray(g, dims=("time_gyro", "filter", "gyro_axis"),
                                coords={"time_gyro": np.asarray(sp["t"], dtype=float), "filter": gyro_names,
                                        "gyro_axis": list(_BODY)},
                                attrs={"units": "arcsec", "long_name": "gyro-angle error (output minus truth)"})
            ds = ds.merge(gyro.to_dataset(name="gyro_error"), join="outer")
        summ = self.summary().reindex(ds["filter"].values if "filter" in ds.dims else self.filters)
        scal = {"horizontal_final": ("horizontal_final_m", "m"), "horizontal_peak": ("horizontal_max_m", "m"),
                "vertical_final": ("vertical_final_m", "m"), "velocity_final": ("velocity_final_m_s", "m/s"),
                "cep_rate": ("cep_rate_nmi_h", "nmi/h")}
        for var, (col, unit) in scal.items():
            if col in summ:
                ds[var] = xr.DataArray(summ[col].to_numpy(dtype=float), dims=("filter",),
                                       attrs={"units": unit, "long_name": f"metrics.json: {col}"})
        for var in ("phi_final", "phi_rms"):
            cols = [f"{var}_{a}_arcsec" for a in _NED]
            if all(c in summ for c in cols):
                ds[var] = xr.DataArray(summ[cols].to_numpy(dtype=float), dims=("filter", "axis"),
                                       attrs={"units": "arcsec", "long_name": f"metrics.json: attitude error {var}"})
        aided = self._aided()
        if aided:   # the aided runs: errors and the filter's 1-sigma per state on (time_aided, filter, aided_state)
            parts = []
            for name, (t, err, sig) in aided.items():
                conv = np.array([ARCSEC if c.endswith("arcsec") else 1.0 for c in _AIDED_COLUMNS])
                parts.append(xr.Dataset({"aided_error": (("time_aided", "aided_state"), err / conv),
                                         "aided_sigma": (("time_aided", "aided_state"), sig[:, :9] / conv)},
                                        coords={"time_aided": np.asarray(t, dtype=float)}))
            ad = xr.concat(parts, dim="filter", join="outer").assign_coords(
                filter=list(aided), aided_state=list(_AIDED_COLUMNS))
            ad["aided_error"].attrs.update(long_name="aided solution's error against the truth (unit in aided_state)")
            ad["aided_sigma"].attrs.update(long_name="the aided filter's 1-sigma (unit in aided_state)")
            ds = ds.merge(ad, join="outer")
        ds["status"] = xr.DataArray(summ["status"].astype(str).to_numpy(), dims=("filter",))
        ds["time"].attrs.update(units="s", long_name="centre of the stored interval")
        ds["time_truth"].attrs.update(units="s")
        ds.attrs.update(scenario=self.name, seed=self.seed, duration_s=self.duration_s, sins_sim_version=__version__,
                        configuration=json.dumps(self.configuration(), default=str))
        return ds

    # --- figures -----------------------------------------------------------------------------------------------
    def plot(self, kind: str = "navigation_error"):
        """One of the CLI's figures of this run, returned (not written): a :class:`matplotlib.figure.Figure`.

        Parameters
        ----------
        kind : str
            One of :data:`FIGURE_KINDS`; :attr:`figures` lists those this run has data for.

        Raises
        ------
        ValueError
            An unknown kind, or one without data in this run (e.g. ``allan`` after :func:`load`: the Allan
            curves are not stored; ``gyro_error_spectrum`` with ``filters: [ideal]``).
        """
        from sins_sim.plots.navigation import run_figure

        if kind not in FIGURE_KINDS:
            raise ValueError(f"plot: unknown figure {kind!r}; one of {', '.join(FIGURE_KINDS)}")
        have = self.figures
        if kind not in have:
            why = (" (the Allan curves are not stored in a result folder; run it again to draw them)"
                   if kind == "allan" and isinstance(self.result, StoredRun) else "")
            raise ValueError(f"plot: {self.name} has no data for the figure {kind!r}{why}; it has: "
                             f"{', '.join(have) or 'none'}")
        return run_figure(self.result, kind, self.name, metrics=self.metrics)

    # --- the folder --------------------------------------------------------------------------------------------
    def save(self, folder, force: bool = False) -> Path:
        """Write the folder ``sins-sim run --out folder`` writes (the same writer): ``metrics.json``,
        ``timeseries.npz``, the figures, ``report.md``, ``manifest.json`` and ``inputs/``.

        The folder appears complete or not at all (:func:`sins_sim.jobs.output.atomic_output_dir`); an
        existing result folder is replaced only with ``force``. The manifest's timings are the run's; its
        inputs are hashed as they are when saving. ``sins-sim run --rerun folder`` runs it again.

        Returns
        -------
        Path
        """
        if self._origin is None or self.scenario is None or isinstance(self.result, StoredRun):
            raise ConfigError("save: this result was loaded from a folder; copy that folder instead")
        self.manifest = self._origin.save(folder, force, self)
        self.folder = Path(folder)
        return self.folder
