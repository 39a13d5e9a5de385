"""
Your unit's log: describe, import, align, navigate
==================================================

A real unit's log has pulse counts in its own axes and no truth attitude. This example makes one, the way a
navigation-grade RLG unit writes it, and takes it through sins-sim with no hand conversion:

1. a vehicle stands still for 10 minutes at 56.8 deg N, heading 85 deg, then drives off; its gyros have
   biases of a few thousandths of a deg/h and the preset's white noise;
2. its log: integer pulse counts per 10 ms (0.1 arcsec and 125 ug s per pulse, each counter carrying its
   residual), right-forward-up axes, the site in header rows;
3. a YAML description of that layout, and ``import-log`` to the project's increments table;
4. the three alignment methods over the first 300 s, against the truth;
5. navigation with no truth from the inertial alignment: the solution and its displacement from the start.

The command-line equivalent of steps 3 to 5 is ``sins-sim import-log LOG --describe LOG.yaml --out
log.parquet`` and ``sins-sim navigate log.parquet --align inertial --imu configs/nav-grade-rlg.yaml --out DIR``.
"""

import math
import tempfile
from pathlib import Path

import numpy as np

from sins_sim import earth
from sins_sim.config.imu import load_imu
from sins_sim.jobs.import_log import import_log, read_log_table
from sins_sim.jobs.navigate import navigate_file
from sins_sim.models.motion import Stationary, Trajectory
from sins_sim.models.motion.trajectory import Accelerate, CoordinatedTurn, Cruise
from sins_sim.navigation.attitude import attitude_error
from sins_sim.plots.alignment import alignment_figure
from sins_sim.simulation.aligning import ALIGNERS, alignment_settings
from sins_sim.simulation.external import ideal_increments
from sins_sim.units import ARCSEC, DEG, DEG_PER_H, MICRO_G

ROOT = next(p for p in (Path.cwd(), *Path.cwd().parents) if (p / "scenarios").is_dir())
RATE_HZ, LAT_DEG, LON_DEG, HEIGHT_M = 100.0, 56.8, 37.6, 150.0

# %%
# 1. The unit's motion and its sensors
# ------------------------------------
# The exact increments of the trajectory (body axes forward-right-down), plus constant biases and white noise
# at the levels of ``configs/nav-grade-rlg.yaml`` (ARW 0.002 deg/sqrt(h), VRW 5 ug/sqrt(Hz)).

truth = Trajectory(LAT_DEG * DEG, LON_DEG * DEG, HEIGHT_M, 0.0, 85.0 * DEG,
                   [Stationary(600.0), Accelerate(20.0, 10.0), CoordinatedTurn(30.0, math.pi / 2), Cruise(30.0)])
t = np.arange(1, int(round(truth.duration_s * RATE_HZ)) + 1) / RATE_HZ
dth, dv = ideal_increments(truth, t)
rng = np.random.default_rng(35)
gyro_bias = np.array([0.003, -0.002, 0.0025]) * DEG_PER_H  # rad/s
accel_bias = np.array([20.0, -15.0, 30.0]) * MICRO_G  # m/s^2
dt = 1.0 / RATE_HZ
dth = dth + gyro_bias * dt + 0.002 * DEG / 60.0 * math.sqrt(dt) * rng.standard_normal(dth.shape)
dv = dv + accel_bias * dt + 5.0 * MICRO_G * math.sqrt(dt) * rng.standard_normal(dv.shape)

# %%
# 2. The log, as the unit writes it
# ---------------------------------
# Right-forward-up axes (right = FRD's y, forward = x, up = -z), integer counts from counters that carry
# their residual, the site in the header.

RFU = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])


def counts(x, weight):
    total = np.floor(np.cumsum(x / weight, axis=0))
    return np.diff(np.vstack([np.zeros((1, 3)), total]), axis=0).astype(np.int64)


work = Path(tempfile.mkdtemp())
ng, na = counts(dth @ RFU.T, 0.1 * ARCSEC), counts(dv @ RFU.T, 125.0 * MICRO_G)
rows = [f"{t[i]:.2f} {ng[i, 0]} {ng[i, 1]} {ng[i, 2]} {na[i, 0]} {na[i, 1]} {na[i, 2]}" for i in range(t.size)]
(work / "unit.log").write_text("\n".join(["RLG unit, pulse log", f"Latitude: {LAT_DEG}", f"Longitude = {LON_DEG}",
                                          f"Height: {HEIGHT_M}", "# time_s gR gF gU aR aF aU", *rows]) + "\n")
print((work / "unit.log").read_text()[:260])

# %%
# 3. Its description, and the import
# ----------------------------------
# ``sins-sim schema log`` lists every key. The table written is the project's increments in FRD, with the
# description, the site and the source's SHA-256 in its metadata.

(work / "unit.yaml").write_text("""\
name: RLG unit, example
format: {type: text, delimiter: whitespace, header_rows: 4, comment: "#"}
columns: {time: 0, gyro: [1, 2, 3], accelerometer: [4, 5, 6]}
time: {unit: s, rate_hz: 100}
gyro: {kind: counts, weight_arcsec: 0.1}
accelerometer: {kind: counts, weight_ug_s: 125}
axes: right-forward-up
site: {lat_deg: {header: Latitude}, lon_deg: {header: Longitude}, height_m: {header: Height}}
""")
meta = import_log(work / "unit.log", work / "unit.yaml", work / "unit.parquet")
t_i, dth_i, dv_i, meta = read_log_table(work / "unit.parquet")
print(f"imported {t_i.size} intervals at {meta['report']['rate_hz']:g} Hz; site lat "
      f"{math.degrees(meta['site']['lat_rad']):.4g} deg")

# %%
# 4. Alignment over the first 300 s, by each method
# -------------------------------------------------
# Each method states a 1-sigma from the observability bounds of the unit's sensor-error model (tilt: the
# accelerometer bias over g; heading: the east gyro bias over Omega cos(lat)) and the data's own scatter, or from
# the filter's covariance (``kalman``). The error is against the truth the log was made from.

sensors = load_imu(ROOT / "configs" / "nav-grade-rlg.yaml").sensors
n_w = int(round(300.0 * RATE_HZ))
site = {"lat_rad": meta["site"]["lat_rad"], "lon_rad": meta["site"]["lon_rad"], "h_m": meta["site"]["height_m"]}
q_true = truth.evaluate([t_i[n_w - 1]]).q_nv[0]
results = {}
print(f"{'method':<10}{'heading error (deg)':>22}{'sigma (deg)':>14}{'tilt error N, E (arcsec)':>28}")
for method in ("coarse", "inertial", "kalman"):
    res = ALIGNERS[method](dth_i[:n_w], dv_i[:n_w], dt, site, alignment_settings(method, 300.0, sensors))
    err = attitude_error(res.q_nb, q_true)
    results[method] = res
    print(f"{method:<10}{math.degrees(err[2]):>22.4f}{math.degrees(res.sigma_rad[2]):>14.4f}"
          f"{err[0] / ARCSEC:>14.2f}, {err[1] / ARCSEC:.2f}")
fig = alignment_figure(results)

# %%
# One noise draw says little on its own. Over 300 s the gyros' white noise alone moves the heading by
# ARW / (Omega cos(lat) sqrt(T)), about 0.048 deg here, on top of the bias term (the east component of these
# biases, 0.0028 deg/h, over Omega cos(lat) = 8.2 deg/h: 0.019 deg, which the preset's bias bound of
# 0.0036 deg/h covers at 0.025 deg). The same still window over 30 noise draws, coarse method:

omega_c = earth.EARTH_RATE_RAD_S * math.cos(LAT_DEG * DEG)
print(f"white-noise floor: {math.degrees(0.002 * DEG / 60.0 / (omega_c * math.sqrt(300.0))):.3f} deg")
still_dth, still_dv = ideal_increments(truth, t[:n_w])
errs, sigmas = [], []
for seed in range(30):
    r = np.random.default_rng(seed)
    a = ALIGNERS["coarse"](still_dth + gyro_bias * dt + 0.002 * DEG / 60.0 * math.sqrt(dt) * r.standard_normal((n_w, 3)),
                           still_dv + accel_bias * dt + 5.0 * MICRO_G * math.sqrt(dt) * r.standard_normal((n_w, 3)),
                           dt, site, alignment_settings("coarse", 300.0, sensors))
    errs.append(math.degrees(attitude_error(a.q_nb, q_true)[2]))
    sigmas.append(math.degrees(a.sigma_rad[2]))
errs, sigmas = np.array(errs), np.array(sigmas)
print(f"n = 30: heading error mean {errs.mean():+.4f} deg, standard deviation {errs.std(ddof=1):.4f} deg; "
      f"stated sigma {sigmas.mean():.4f} deg on average; |error| within 1 sigma on {np.mean(np.abs(errs) <= sigmas):.0%}"
      f", within 2 sigma on {np.mean(np.abs(errs) <= 2 * sigmas):.0%}")

# %%
# The closed forms, and why a swaying base defeats the coarse method: :doc:`/theory/alignment`.

# %%
# 5. Navigation with no truth
# ---------------------------
# From the inertial alignment, free inertial with the height held at the site's: the solution's displacement
# from where it started. The vehicle stood still for 5 more minutes, then drove off.

m = navigate_file(work / "unit.parquet", None, work / "out", align="inertial", align_duration_s=300.0,
                  imu=ROOT / "configs" / "nav-grade-rlg.yaml")
f = m["solution"]["final_displacement_m"]
print(f"final displacement: north {f['north']:.1f} m, east {f['east']:.1f} m; files: "
      f"{sorted(p.name for p in (work / 'out').iterdir())}")

# %%
from sins_sim.plots.alignment import displacement_figure  # noqa: E402

sol = __import__("pandas").read_parquet(work / "out" / "solution.parquet")
fig = displacement_figure(sol["time_s"].to_numpy(), sol[["north_m", "east_m", "up_m"]].to_numpy())
