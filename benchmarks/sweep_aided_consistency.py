"""NEES coverage of the aided filter over Monte Carlo seeds on a scenario's trajectory, fixes and filter model.

The numbers of the bundled helicopter in ``docs/user-guide/aided.md`` ("Example")::

    PYTHONPATH=. python benchmarks/sweep_aided_consistency.py scenarios/helicopter-aided.yaml --seeds 800
    PYTHONPATH=. python benchmarks/sweep_aided_consistency.py scenarios/helicopter-aided.yaml --seeds 800 \
        --sensor-states none

What is simulated: the scenario's trajectory (its vehicle), fixes, aiding settings and the filter's model
(:meth:`~sins_sim.simulation.aiding.AidedMission.model`, the mission's own), at the mission's epochs. What is not:
the channel simulation (the increments are the trajectory's exact ones at ``--rate-hz``, so no vibration, no
dither filter, no bias instability; minutes per seed otherwise). Per seed, drawn from the sigmas the filter is
told: the gyro and accelerometer biases, a constant scale-factor and misalignment matrix per sensor triad, white
angle and velocity random walk, the initial navigation errors (the filter's prior without the bias part: the drawn
matrix adds its constant part itself), and the fixes' white and Gauss-Markov errors.

Printed per block (position, velocity, attitude): the fraction of epochs whose seed-averaged NEES lies inside the
chi-square 95 % interval of a mean of ``N`` (``chi2(3 N) / N``), the fractions below and above it, the mean NEES,
the effective number of independent epochs and the Clopper-Pearson 95 % interval of the fraction
(``tests/test_aided_consistency.py``'s ``coverage``), and the mean NEES in and after each outage.

The fraction of one set of seeds swings between sets far more than that interval says when part of a seed's
error stays for the whole run (here the position, which the fixes cannot tell from their 300 s Gauss-Markov
error: correlated 0.9 over 40 s; the down velocity, 0.4 over 40 s): with ``--seeds`` at least twice ``--set-size`` (50)
the fraction is also given per disjoint set, with its mean, the spread between sets and the Clopper-Pearson
interval of the mean over the binomial-equivalent epochs the sets show (``set_coverage``), and per component the
mean of ``e^2 / P`` over seeds and run with its standard error. ``--seed-start`` picks the seeds;
``--noise-free`` switches every random error off (the NEES left is the deterministic floor, about 0).

``--sensor-states gyro_scale_factor,gyro_misalignment`` estimates those groups as filter states (the drawn matrices
are the same; the states' priors are the sigmas they are drawn from), ``--save FILE.npz`` keeps the epochs and the
seed-averaged NEES per block, and per seed the NEES, the errors and ``e^2 / P``, for a closer look.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
from pathlib import Path

import numpy as np
from scipy.stats import chi2

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))


def main(argv=None) -> None:
    from test_aided_consistency import coverage, set_coverage

    from sins_sim import earth
    from sins_sim.config.scenario import load_scenario
    from sins_sim.navigation import ekf
    from sins_sim.navigation.aided import navigate_aided
    from sins_sim.navigation.attitude import quat_from_rotvec, quat_multiply
    from sins_sim.navigation.gnss import simulate_gnss
    from sins_sim.simulation.aiding import AidedMission, _prior
    from sins_sim.simulation.external import ideal_increments

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenario")
    ap.add_argument("--seeds", type=int, default=50)
    ap.add_argument("--seed-start", type=int, default=0, help="the first seed (seeds seed-start .. seed-start + seeds - 1)")
    ap.add_argument("--noise-free", action="store_true",
                    help="every random error off (biases, scale factors, misalignments, white noise, initial errors, "
                         "the fixes' errors): the NEES left is the deterministic floor")
    ap.add_argument("--rate-hz", type=float, default=50.0, help="increment rate (Hz), a multiple of the fix rate")
    ap.add_argument("--duration-s", type=float, default=None, help="shorter than the scenario's")
    ap.add_argument("--fix-model", choices=("scenario", "states", "fold"), default="scenario",
                    help="the fixes' Gauss-Markov error as filter states or folded into R (default: the scenario's "
                         "aiding.fix_error_states)")
    ap.add_argument("--sensor-states", default=None,
                    help="comma-separated scale-factor and misalignment groups as filter states (gyro_scale_factor, "
                         "gyro_misalignment, accel_scale_factor, accel_misalignment; 'none'); default: the "
                         "scenario's aiding.sensor_error_states")
    ap.add_argument("--set-size", type=int, default=50,
                    help="seeds per disjoint set for the judgement over sets (printed with at least two sets)")
    ap.add_argument("--save", default=None, help="write the epochs and the seed-averaged NEES to this .npz")
    a = ap.parse_args(argv)
    sc = load_scenario(a.scenario)
    nav, aid = sc.nav, sc.nav.aiding
    if aid is None or sc.vehicle is None:
        raise SystemExit(f"{a.scenario}: needs aiding: and a trajectory")
    if a.fix_model != "scenario":
        aid = dataclasses.replace(aid, fix_error_states=a.fix_model == "states")
    if a.sensor_states is not None:
        groups = tuple(x.strip() for x in a.sensor_states.split(",") if x.strip() and x.strip() != "none")
        aid = dataclasses.replace(aid, sensor_error_states=groups)
    g = aid.gnss
    g_truth = g if not a.noise_free else dataclasses.replace(g, position_sigma_m=(1e-300,) * 3,
                                                             velocity_sigma_m_s=(1e-300,) * 3,
                                                             markov_sigma_m=(0.0,) * 3)
    dur = float(a.duration_s or sc.duration_s)
    t0, fs = nav.start_s, a.rate_hz
    dt = 1.0 / fs
    n = int(round((dur - t0) * fs))
    t = t0 + dt * np.arange(1, n + 1)
    dth_true, dv_true = ideal_increments(sc.vehicle, t)
    tt = np.concatenate([[t0], t])
    truth = sc.vehicle.evaluate(tt)
    mission = AidedMission(aid, nav.alignment, fs, 1, dur, 0, lambda name: ("two_sample", "two_sample"),
                           sensors=sc.imu.sensors, vehicle=sc.vehicle)
    model = mission.model(t0, dur)
    noise, un = model.noise, model.unmodelled
    prior = _prior(aid, None)
    p0 = model.initial_covariance(*prior)
    p0_truth = ekf.initial_covariance(*prior, noise)
    out_t = mission.output_times(t0, dur)
    blocks = (ekf.POS, ekf.VEL, ekf.ATT)
    per_seed = []
    for seed in range(a.seed_start, a.seed_start + a.seeds):
        rng = np.random.default_rng([seed, 3737])
        bg = rng.normal(0.0, noise.gyro_bias_sigma_rad_s, 3)
        ba = rng.normal(0.0, noise.accel_bias_sigma_m_s2, 3)
        k = {}
        for name, s_s, s_m in (("gyro", un.gyro_scale_factor, un.gyro_misalignment_rad),
                               ("accel", un.accel_scale_factor, un.accel_misalignment_rad)):
            m = rng.normal(0.0, s_m, (3, 3))
            np.fill_diagonal(m, rng.normal(0.0, s_s, 3))
            k[name] = np.eye(3) + m
        wg = rng.normal(0.0, noise.gyro_arw_rad_sqrt_s * math.sqrt(dt), (n, 3))
        wa = rng.normal(0.0, noise.accel_vrw_m_s_sqrt_s * math.sqrt(dt), (n, 3))
        x0 = rng.multivariate_normal(np.zeros(ekf.N_STATES), p0_truth)
        if a.noise_free:
            bg, ba, wg, wa, x0 = 0.0 * bg, 0.0 * ba, 0.0 * wg, 0.0 * wa, 0.0 * x0
            k = {"gyro": np.eye(3), "accel": np.eye(3)}
        dth = dth_true @ k["gyro"].T + bg * dt + wg
        dv = dv_true @ k["accel"].T + ba * dt + wa
        r_n, r_e = earth.radii(truth.lat_rad[0])
        lat, h = float(truth.lat_rad[0]), float(truth.h_m[0])
        start = ekf.NavState(t0, lat + x0[0] / (r_n + h), truth.lon_rad[0] + x0[1] / ((r_e + h) * math.cos(lat)),
                             h - x0[2], truth.v_ned_m_s[0] + x0[3:6],
                             quat_multiply(quat_from_rotvec(x0[6:9]), truth.q_nv[0]), np.zeros(3), np.zeros(3))
        fixes = simulate_gnss(tt, truth.lat_rad, truth.lon_rad, truth.h_m, truth.v_ned_m_s, g_truth, rng,
                              q_nb=truth.q_nv, omega_ib_b_rad_s=truth.omega_iv_v_rad_s)
        fixes = dataclasses.replace(fixes, position_sigma_m=np.asarray(model.position_sigma_m, dtype=float),
                                    velocity_sigma_m_s=np.asarray(model.velocity_sigma_m_s, dtype=float))
        res = navigate_aided(t, dth, dv, start, noise, p0, fixes, output_t_s=out_t, use=aid.measurements,
                             max_propagation_s=1.0 / aid.update_rate_hz, unmodelled=un, fix_errors=model.fix_errors)
        o = sc.vehicle.evaluate(res.t_s)
        e = res.errors(o.lat_rad, o.lon_rad, o.h_m, o.v_ned_m_s, o.q_nv)[1:]
        p = res.p_upd[1:]
        nees = np.stack([np.einsum("ki,ki->k", e[:, b], np.linalg.solve(p[:, b, b], e[:, b, None])[..., 0])
                         for b in blocks], axis=1)
        # per component: the squared error over its variance (its mean over seeds is 1 for a consistent filter)
        per_seed.append((nees, e[:, :9] ** 2 / np.diagonal(p, axis1=1, axis2=2)[:, :9], e[:, :9]))
    nees_s, z2_s, e_s = (np.stack(x) for x in zip(*per_seed))
    nees = nees_s.mean(axis=0)
    t_ep = res.t_s[1:]
    lo, hi = chi2.ppf([0.025, 0.975], 3 * a.seeds) / a.seeds
    if a.save:
        np.savez(a.save, t_s=t_ep, nees=nees, lo=lo, hi=hi, seeds=np.arange(a.seed_start, a.seed_start + a.seeds),
                 nees_per_seed=nees_s, z2_per_seed=z2_s, errors_per_seed=e_s)
    print(f"{a.scenario}: {a.seeds} seeds, {dur:g} s, {t_ep.size} epochs, interval [{lo:.3f}, {hi:.3f}], "
          f"{model.record['states']} states (Gauss-Markov fix error: {model.record['gnss_markov']}; sensor-error "
          f"states: {model.record['sensor_error_states']})")
    for name, (frac, n_eff, c_lo, c_hi), col in zip(("position", "velocity", "attitude"), coverage(nees, a.seeds),
                                                   nees.T):
        print(f"  {name}: inside {frac:.3f} (below {np.mean(col < lo):.3f}, above {np.mean(col > hi):.3f}), "
              f"mean {col.mean():.2f}, n_eff {n_eff:.1f}, Clopper-Pearson 95 % [{c_lo:.3f}, {c_hi:.3f}]")
    z2_mean = z2_s.mean(axis=1)         # per seed, the run's mean of e_i^2 / P_ii
    print("  e^2 / P per component (N E D position, velocity, psi), mean over the seeds and the run +- its standard "
          "error over the seeds: " + ", ".join(f"{m:.2f}+-{se:.2f}" for m, se in
                                              zip(z2_mean.mean(axis=0), z2_mean.std(axis=0) / math.sqrt(a.seeds))))
    if a.seeds >= 2 * a.set_size:
        sets = set_coverage(nees_s, a.set_size)
        n_sets = sets["fractions"].shape[0]
        print(f"  over {n_sets} disjoint sets of {a.set_size} seeds (the first {n_sets * a.set_size}):")
        for b, name in enumerate(("position", "velocity", "attitude")):
            f = sets["fractions"][:, b]
            print(f"    {name}: per set {' '.join(f'{x:.2f}' for x in f)}; mean {sets['mean'][b]:.3f}, sd {sets['sd'][b]:.3f}, "
                  f"sets >= 0.90: {np.mean(f >= 0.9):.2f}, n_b {sets['n_b'][b]:.1f} epochs per set, Clopper-Pearson "
                  f"95 % of the mean [{sets['interval'][b, 0]:.3f}, {sets['interval'][b, 1]:.3f}]")
    for w0, w1 in g.outages_s:
        inside = (t_ep > w0) & (t_ep <= w1)
        after = (t_ep > w1) & (t_ep <= w1 + 20.0)
        print(f"  outage {w0:g}-{w1:g} s: mean NEES {np.round(nees[inside].mean(axis=0), 2).tolist()}, "
              f"20 s after: {np.round(nees[after].mean(axis=0), 2).tolist()}")


if __name__ == "__main__":
    main()
