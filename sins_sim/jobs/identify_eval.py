"""``sins-sim identify-eval``: the twin's verdict checked blind on logs of random units with withheld effects.

Each case is a log at rest of a unit drawn at random (:func:`draw_unit`: ARW, a rate random walk, VRW, biases,
heading and latitude), with one withheld effect (:data:`CLASSES`), made by the simulator's own error models
(:func:`sins_sim.simulation.twin.twin_increments`) plus the effect, written in a foreign layout (a semicolon CSV
of rates in deg/h and mg along right-forward-up axes, the site in header lines, :data:`DESCRIPTION`), read back
by ``import-log`` and judged by ``identify`` with its twin. The right answer per class:

========================= ============================================================ ==================
class                     withheld effect                                              right verdict
========================= ============================================================ ==================
``none``                  nothing                                                      ``none``
``sway``                  a gyro line, 0.2-0.8 Hz, 0.3-0.6 arcsec                      ``explained`` by ``base_motion_line``
``vibration``             an accelerometer line, 15-40 Hz, 1-3 mg                      ``explained`` by ``base_motion_line``
``bias_step``             a gyro bias step at 30-70 % of the log, 70-90 white sigmas   ``explained`` by ``bias_step``
``noise_burst``           (outside the catalogue) the white noise of one gyro          ``unknown``
                          tripled over a fifth of the log
``square_wave``           (outside the catalogue) a gyro bias switching between +-b    ``unknown``
                          three times over the log (a thermostat cycling), b as a step
``time_gap``              1-20 rows dropped from the file mid-way                      ``invalid data``
========================= ============================================================ ==================

Scored per class over :data:`SEEDS` (looked at while developing) and, with ``holdout``, :data:`HOLDOUT_SEEDS`
(kept unlooked-at until the end).
"""

from __future__ import annotations

import math
import tempfile
from pathlib import Path

import numpy as np

__all__ = ["CLASSES", "DESCRIPTION", "HOLDOUT_SEEDS", "SEEDS", "draw_unit", "identify_eval", "format_identify_eval",
           "write_case"]

#: The withheld-effect classes and their right answer (status, effect or None).
CLASSES = {"none": ("none", None), "sway": ("explained", "base_motion_line"),
           "vibration": ("explained", "base_motion_line"), "bias_step": ("explained", "bias_step"),
           "noise_burst": ("unknown", None), "square_wave": ("unknown", None), "time_gap": ("invalid data", None)}
#: Seeds looked at while developing, and the two kept unlooked-at until the end.
SEEDS = (0, 1, 2)
HOLDOUT_SEEDS = (101, 102)
#: The foreign layout's description (``sins-sim schema log``).
DESCRIPTION = {
    "name": "identify-eval unit",
    "format": {"type": "csv", "delimiter": "semicolon", "header_rows": 3, "comment": "#"},
    "columns": {"time": "t", "gyro": ["wR", "wF", "wU"], "accelerometer": ["fR", "fF", "fU"]},
    "time": {"unit": "s", "gaps": "refuse"},
    "gyro": {"kind": "rates", "unit": "deg_h"},
    "accelerometer": {"kind": "rates", "unit": "mg"},
    "axes": "right-forward-up",
    "site": {"lat_deg": {"header": "Latitude"}, "lon_deg": {"header": "Longitude"}, "height_m": {"header": "Height"}},
}
_FS = 100.0


def draw_unit(rng) -> dict:
    """A navigation-grade unit at random: its ``sensors:`` mapping, heading (rad) and site."""
    arw = float(rng.uniform(0.002, 0.005))
    cross = float(rng.uniform(50.0, 300.0))      # where the random walk's Allan slope crosses the white one (s)
    # sigma_N(tau) = N / sqrt(tau), sigma_K(tau) = K sqrt(tau / 3): equal at tau_c for K = sqrt(3) N / tau_c (rad/s^1.5);
    # in deg/h/sqrt(h): N [deg/sqrt(h)] * 60 * sqrt(3) / tau_c * 60
    rrw = arw * math.sqrt(3.0) / cross * 3600.0
    sensors = {"gyro": {"arw_deg_rt_h": [arw] * 3, "rrw_deg_h_rt_h": [rrw] * 3,
                        "bias_deg_h": rng.uniform(-0.02, 0.02, 3).tolist()},
               "accelerometer": {"vrw_ug_rt_hz": [float(rng.uniform(10.0, 40.0))] * 3,
                                 "bias_ug": rng.uniform(-100.0, 100.0, 3).tolist()}}
    return {"sensors": sensors, "heading_rad": float(rng.uniform(0.0, 2 * math.pi)),
            "site": {"lat_rad": math.radians(float(rng.uniform(20.0, 60.0))), "lon_rad": math.radians(30.0),
                     "height_m": float(rng.uniform(0.0, 500.0))}}


def _sine(amp, f_hz, t, dt):
    """Interval means of ``amp sin(2 pi f t)`` over ``(t - dt, t]``."""
    w = 2.0 * math.pi * f_hz
    return amp / (w * dt) * (np.cos(w * (t - dt)) - np.cos(w * t))


def write_case(path, cls: str, seed: int, minutes: float) -> dict:
    """Write one case's log in the foreign layout at ``path`` (and its description beside it); returns the truth."""
    from sins_sim.models.sensor_errors import sensor_params_from_dict
    from sins_sim.navigation.attitude import quat_from_rotvec
    from sins_sim.simulation.twin import twin_increments
    from sins_sim.units import ARCSEC, DEG_PER_H, MICRO_G

    if cls not in CLASSES:
        raise ValueError(f"class: must be one of {list(CLASSES)}, got {cls!r}")
    rng = np.random.default_rng([seed, list(CLASSES).index(cls)])
    unit = draw_unit(rng)
    dt = 1.0 / _FS
    n = int(round(minutes * 60.0 * _FS))
    q = quat_from_rotvec(np.array([0.0, 0.0, unit["heading_rad"]]))
    t, dth, dv = twin_increments(sensor_params_from_dict(unit["sensors"], "identify-eval unit"), n, dt, unit["site"],
                                 q, int(rng.integers(2 ** 31)))
    rate, force = dth / dt, dv / dt
    truth = {"class": cls, "seed": seed, "unit": unit}
    ax = int(rng.integers(3))
    if cls == "sway":
        f, ang = float(rng.uniform(0.2, 0.8)), float(rng.uniform(0.3, 0.6))
        rate[:, ax] += _sine(2 * math.pi * f * ang * ARCSEC, f, t, dt)
        truth.update(axis=ax, frequency_hz=f, angle_arcsec=ang)
    elif cls == "vibration":
        f, amp = float(rng.uniform(15.0, 40.0)), float(rng.uniform(1000.0, 3000.0))
        force[:, ax] += _sine(amp * MICRO_G, f, t, dt)
        truth.update(axis=ax, frequency_hz=f, amplitude_ug=amp)
    elif cls == "bias_step":
        t_s = float(rng.uniform(0.3, 0.7)) * t[-1]
        n_sig = unit["sensors"]["gyro"]["arw_deg_rt_h"][0] * DEG_PER_H * 60.0 * math.sqrt(_FS)   # per-sample sigma
        # 70-90 white-noise sigmas of a mid-log step's size: the step scan's sigma, with the random walk's
        # correlation, is about ten times the white one (a 1 deg/h step in 8 min of 0.003 deg/sqrt(h): z 5.8 against 61)
        k = float(rng.uniform(70.0, 90.0))
        size = k * n_sig * 2.0 / math.sqrt(n)
        rate[t > t_s, ax] += size
        truth.update(axis=ax, time_s=t_s, size_deg_h=size / DEG_PER_H)
    elif cls == "noise_burst":
        n_sig = unit["sensors"]["gyro"]["arw_deg_rt_h"][0] * DEG_PER_H * 60.0 * math.sqrt(_FS)
        i0 = int(rng.uniform(0.2, 0.6) * n)
        rate[i0:i0 + n // 5, ax] += 2.0 * math.sqrt(2.0) * n_sig * rng.standard_normal(n // 5)[: n - i0]
        truth.update(axis=ax, start_s=float(t[i0]))
    elif cls == "square_wave":
        n_sig = unit["sensors"]["gyro"]["arw_deg_rt_h"][0] * DEG_PER_H * 60.0 * math.sqrt(_FS)
        b = float(rng.uniform(70.0, 90.0)) * n_sig * 2.0 / math.sqrt(n)     # as large as a step
        rate[:, ax] += b * np.where(np.sin(2 * math.pi * 3.0 * t / t[-1]) >= 0.0, 1.0, -1.0)
        truth.update(axis=ax, half_size_deg_h=b / DEG_PER_H)
    keep = np.ones(n, dtype=bool)
    if cls == "time_gap":
        i0, k = int(rng.uniform(0.3, 0.7) * n), int(rng.integers(1, 21))
        keep[i0:i0 + k] = False
        truth.update(rows_dropped=k, at_s=float(t[i0]))
    # FRD -> right-forward-up: (R, F, U) = (y, x, -z)
    perm = lambda v: np.column_stack([v[:, 1], v[:, 0], -v[:, 2]])  # noqa: E731
    g, a = perm(rate / DEG_PER_H), perm(force / (1e-3 * 9.80665))
    site = unit["site"]
    lines = [f"Latitude: {math.degrees(site['lat_rad']):.8f}", f"Longitude: {math.degrees(site['lon_rad']):.8f}",
             f"Height: {site['height_m']:.3f}", "t;wR;wF;wU;fR;fF;fU"]
    rows = np.column_stack([t, g, a])[keep]
    lines += [";".join(f"{x:.12g}" for x in r) for r in rows]
    Path(path).write_text("\n".join(lines) + "\n")
    return truth


def _judge(log: Path, work: Path, twin_seeds: int) -> dict:
    from sins_sim.config.errors import ConfigError
    from sins_sim.identification.twin_explain import invalid_data
    from sins_sim.jobs.identify import identify
    from sins_sim.jobs.import_log import import_log

    table = work / (log.stem + ".parquet")
    try:
        import_log(log, DESCRIPTION, table, force=True)
        return identify(table, twin_seeds=twin_seeds)["verdict"]
    except (ConfigError, ValueError) as exc:     # the log's refusals: LogFileError is a ValueError
        return invalid_data(" ".join(str(exc).split()))


def identify_eval(seeds=SEEDS, *, holdout: bool = False, minutes: float = 3.0, twin_seeds: int = 5,
                  classes=None, progress=None) -> dict:
    """Score ``identify``'s verdicts per class (module docstring).

    Parameters
    ----------
    seeds : sequence of int
        The seeds looked at.
    holdout : bool
        Also score :data:`HOLDOUT_SEEDS`, reported apart.
    minutes : float
        Each log's length.
    twin_seeds : int
        The twin's seeds in ``identify``.
    classes : sequence of str, optional
        A subset of :data:`CLASSES`.
    progress : callable, optional
        Called with one line per case.

    Returns
    -------
    dict
        ``cases`` (class, seed, set, truth, status, effect, right), ``accuracy`` (``looked`` and ``holdout``: class
        -> [right, total]).
    """
    classes = list(classes or CLASSES)
    for c in classes:
        if c not in CLASSES:
            raise ValueError(f"classes: must be among {list(CLASSES)}, got {c!r}")
    if not (isinstance(minutes, (int, float)) and minutes >= 1.0):
        raise ValueError(f"minutes: must be a number >= 1 (the twin's Allan and step scans need a minute), got "
                         f"{minutes!r}")
    runs = [("looked", s) for s in seeds] + ([("holdout", s) for s in HOLDOUT_SEEDS] if holdout else [])
    cases = []
    with tempfile.TemporaryDirectory(prefix="identify-eval-") as tmp:
        work = Path(tmp)
        for which, seed in runs:
            for cls in classes:
                log = work / f"{cls}-{seed}.csv"
                truth = write_case(log, cls, seed, minutes)
                v = _judge(log, work, twin_seeds)
                want_status, want_effect = CLASSES[cls]
                right = v["status"] == want_status and (want_effect is None or v["effect"] == want_effect)
                cases.append({"class": cls, "seed": seed, "set": which, "status": v["status"], "effect": v["effect"],
                              "explained_fraction": v.get("explained_fraction"), "right": right, "truth": truth})
                if progress is not None:
                    progress(f"{which} seed {seed} {cls}: {v['status']} ({v['effect']}) "
                             f"{'right' if right else 'WRONG'}")
    acc = {}
    for which in ("looked", "holdout"):
        acc[which] = {c: [sum(x["right"] for x in cases if x["class"] == c and x["set"] == which),
                          sum(1 for x in cases if x["class"] == c and x["set"] == which)] for c in classes}
    return {"cases": cases, "accuracy": acc, "minutes": minutes, "twin_seeds": twin_seeds}


def format_identify_eval(result: dict) -> str:
    """The accuracy per class as a table (looked-at seeds, held-out seeds)."""
    out = ["class          right verdict                     looked   holdout"]
    for c, (want, eff) in CLASSES.items():
        if c not in result["accuracy"]["looked"]:
            continue
        lk, ho = result["accuracy"]["looked"][c], result["accuracy"]["holdout"][c]
        label = want + (f" ({eff})" if eff else "")
        out.append(f"{c:<14} {label:<33} {lk[0]}/{lk[1]:<6} {ho[0]}/{ho[1]}" if ho[1] else
                   f"{c:<14} {label:<33} {lk[0]}/{lk[1]}")
    return "\n".join(out)
