"""
GNSS-aided navigation with an outage
====================================

A tactical unit (1 deg/h, 500 ug, ARW 0.05 deg/sqrt(h), VRW 50 ug/sqrt(Hz)) flies at 100 m/s: a straight leg, a
180 deg coordinated turn, another straight leg. GNSS fixes at 5 Hz (2 m, 0.1 m/s) aid it through the
closed-loop 15-state error-state filter, except in a 90 s outage. The figures: the errors inside the filter's
3-sigma, the bias estimates converging, the error growth in the outage against the filter's prediction, and
the innovations. The equations: :doc:`/theory/aided`.
"""

# %%
# The truth and the unit. The increments are the exact ones of the trajectory plus constant biases and white
# noise drawn from the filter's own sensor model; the filter starts from the truth with errors drawn from its
# initial covariance.
import math

import numpy as np

from sins_sim import earth
from sins_sim.models.motion import CoordinatedTurn, Cruise, Trajectory
from sins_sim.navigation import (
    GnssSettings,
    ImuNoise,
    NavState,
    initial_covariance,
    navigate_aided,
    outage_growth,
    quat_from_rotvec,
    quat_multiply,
    simulate_gnss,
)
from sins_sim.plots.aided import (
    aided_error_figure,
    bias_figure,
    innovation_figure,
    outage_growth_figure,
)
from sins_sim.simulation.external import ideal_increments

DT = 0.05                                                     # 20 Hz increments
DURATION = 300.0
traj = Trajectory(math.radians(45.0), math.radians(10.0), 1000.0, 100.0, math.radians(30.0),
                  [Cruise(60.0), CoordinatedTurn(60.0, math.pi), Cruise(180.0)])
t = DT * np.arange(1, round(DURATION / DT) + 1)
dtheta, dv = ideal_increments(traj, t)
t_truth = np.concatenate([[0.0], t])
truth = traj.evaluate(t_truth)

noise = ImuNoise.from_datasheet(gyro_arw_deg_sqrt_h=0.05, accel_vrw_ug_sqrt_hz=50.0, gyro_bias_deg_h=1.0,
                                accel_bias_ug=500.0)
p0 = initial_covariance(pos_sigma_m=2.0, vel_sigma_m_s=0.1, tilt_sigma_rad=2e-4, heading_sigma_rad=5e-3,
                        noise=noise)
rng = np.random.default_rng(2026)
gyro_bias = rng.normal(0.0, noise.gyro_bias_sigma_rad_s, 3)
accel_bias = rng.normal(0.0, noise.accel_bias_sigma_m_s2, 3)
dtheta = dtheta + gyro_bias * DT + rng.normal(0.0, noise.gyro_arw_rad_sqrt_s * math.sqrt(DT), dtheta.shape)
dv = dv + accel_bias * DT + rng.normal(0.0, noise.accel_vrw_m_s_sqrt_s * math.sqrt(DT), dv.shape)

x0 = rng.multivariate_normal(np.zeros(15), p0)                # initial errors: computed minus true
lat0, h0 = float(truth.lat_rad[0]), float(truth.h_m[0])
r_n, r_e = earth.radii(lat0)
start = NavState(0.0, lat0 + x0[0] / (r_n + h0), truth.lon_rad[0] + x0[1] / ((r_e + h0) * math.cos(lat0)),
                 h0 - x0[2], truth.v_ned_m_s[0] + x0[3:6], quat_multiply(quat_from_rotvec(x0[6:9]), truth.q_nv[0]),
                 gyro_bias_rad_s=gyro_bias + x0[9:12], accel_bias_m_s2=accel_bias + x0[12:15])

# %%
# GNSS at 5 Hz with a 90 s outage, and the aided run. The solution is recorded at every fix and once a second;
# the outage growth is read at 10, 30, 60 and 89 s after the last fix before the outage, so those times are
# recorded too.
outages = [(180.0, 270.0)]
settings = GnssSettings(rate_hz=5.0, position_sigma_m=2.0, velocity_sigma_m_s=0.1, outages_s=outages)
fixes = simulate_gnss(t_truth, truth.lat_rad, truth.lon_rad, truth.h_m, truth.v_ned_m_s, settings, rng)
after = np.array([10.0, 30.0, 60.0, 89.0])
t_last_fix = outages[0][0] - 1.0 / settings.rate_hz
result = navigate_aided(t, dtheta, dv, start, noise, p0, fixes,
                        output_t_s=np.union1d(np.arange(0.0, DURATION + 0.5, 1.0), t_last_fix + after))
at = traj.evaluate(result.t_s)
errors = result.errors(at.lat_rad, at.lon_rad, at.h_m, at.v_ned_m_s, at.q_nv)
growth = outage_growth(result, outages, after_s=after, errors=errors)
print(f"{len(result)} epochs, {int(result.updated.sum())} fix updates")
for tau, err, sig in zip(growth[0].after_s, growth[0].error_m, growth[0].predicted_sigma_m):
    print(f"{tau:4.0f} s into the outage: horizontal error {err:6.2f} m, predicted 1-sigma {sig:6.2f} m")

# %%
# The errors north, east and down, each inside the filter's +-3-sigma. The heading (psi down) is not observable
# on the first straight leg and converges in the turn; in the outage the horizontal errors grow as the Schuler
# and bias terms say, and the first fix after it pulls them back.
fig = aided_error_figure(result, errors, outages)

# %%
# The sensor biases. The vertical accelerometer converges at once. On a straight leg the fixes see a horizontal
# accelerometer bias only together with the tilt, as ``g psi + a``, so it is known as well as the tilt's prior
# allows; the turn turns the body under the specific force and separates them. The horizontal gyros converge
# over minutes; the vertical one (z, down in level flight) hardly moves from its prior in so short a flight.
fig = bias_figure(result, gyro_bias, accel_bias, outages_s=outages)

# %%
# The horizontal error in the outage against the filter's prediction (the covariance propagated from the last
# fix with no update), and in units of the predicted sigma below.
fig = outage_growth_figure(growth, result=result)

# %%
# The innovations: normalised by their predicted sigma, and the NIS averaged over 25 fixes against its chi-square
# interval. A filter whose noise model is right keeps both inside their bounds without knowing the truth.
fig = innovation_figure(result, outages_s=outages)
