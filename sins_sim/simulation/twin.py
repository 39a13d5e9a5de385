"""A unit's twin at rest beside its log: the same mission run on the log and on seeds of the twin.

The mission of a log at rest (:func:`rest_run`), run alike on the log and on each seed of the twin:

1. the Allan deviation of each gyro (rate) and accelerometer (specific force) axis
   (:func:`sins_sim.navigation.allan.allan_deviation`);
2. the PSD of each and its lines (:func:`sins_sim.navigation.spectral_lines.find_lines`);
3. the self-alignment over the whole record (coarse or inertial, :mod:`sins_sim.navigation.alignment`);
4. free navigation from that alignment (:func:`sins_sim.simulation.external.navigate_free`, the start height
   held): at rest its position is its error (the displacement from the start), its velocity too, and its
   attitude's rotation from the aligned start (:func:`sins_sim.navigation.attitude.attitude_error` of the
   attitude against the start's, about north, east, down) the attitude drift.

The twin (:func:`twin_increments`) is simulated at the log's own level, the increments after dither removal:
the exact increments of a unit at rest at the site (the Earth's rate and normal gravity seen in body axes at
the log's aligned attitude; Titterton and Weston 2004, sec. 10.2) with the twin's ``sensors:`` errors applied
(:class:`sins_sim.models.sensor_errors.GyroErrors`, :class:`~sins_sim.models.sensor_errors.AccelErrors`: noise,
biases, scale factors). The dither chain is not re-run: what it leaves in a real log (a line at the dither
frequency, folded) is a line the twin has not, which is what the comparison is to show.

The readout's pulses (:class:`PulseWeights`, :func:`quantise_pulses`): a unit whose log holds pulse counts
outputs, per interval, the whole pulses its counter accumulated; the part of a pulse not yet emitted is carried
into the next interval (Savage 2007, sec. 7.1.2.3, integrating sensors with pulse outputs). The twin does the same
in the log's own channel axes, with the log's pulse weights, each counter starting at a residue drawn uniformly in
``[0, 1)`` pulse per seed (a real counter's residue at the log's first row is unknown). On a constant input of
``x`` pulses per interval the output is a periodic pattern with lines at ``frac(x) f_s`` and its harmonics
(folded), and the angle read off the counts is the true one to within one pulse, so the Allan deviation carries
the quantisation slope ``sqrt(3) Q / tau`` with ``Q = q / sqrt(12)`` (IEEE Std 952-1997, Annex C, C.1).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["ALIGNMENT_AT_REST", "PULSE_TOLERANCE", "PulseWeights", "RestRun", "align_at_rest", "checked_added", "gyro_wander_sigma", "pulse_weight_of",
           "quantise_pulses", "rest_run", "twin_increments", "twin_runs"]

#: The self-alignments a log at rest is aligned with.
ALIGNMENT_AT_REST = ("coarse", "inertial")
SENSORS = ("gyro", "accelerometer")
#: Relative distance from a whole number of pulses within which an increment counts as a whole number of pulses
#: (:func:`pulse_weight_of`): float64 pulses times a weight, rotated by a signed permutation, are exact to a few
#: units of 1e-16; 1e-9 leaves room for a text log's decimals (9 significant digits) and none for real noise.
PULSE_TOLERANCE = 1e-9
#: Most of a pulse the tolerance may reach on the largest count (``PULSE_TOLERANCE`` times it): 1 % of a pulse,
#: i.e. counts up to 1e7 per interval. An unquantised float log's smallest step between distinct values is a few
#: ulps of its largest, some 1e9 to 1e13 "pulses", where the relative tolerance passes any value as a whole number.
MAX_PULSE_SLACK = 0.01


@dataclass(frozen=True)
class PulseWeights:
    """The readout's pulse weights of a unit's log (module docstring).

    Attributes
    ----------
    gyro_rad, accel_m_s : ndarray, shape (3,)
        The value of one pulse of each log channel (signed: a channel counting against its axis); 0 for a channel
        that is not quantised.
    axes : ndarray, shape (3, 3)
        Rows: the log's channel axes expressed in body FRD (``v_log = axes @ v_frd``).
    source : str
        Where the weights came from (the log's description, or read off the increments).
    """

    gyro_rad: np.ndarray
    accel_m_s: np.ndarray
    axes: np.ndarray
    source: str

    def to_dict(self) -> dict:
        """The weights at the edges: arcsec and ug s (``1 ug s`` = 9.80665e-6 m/s), the axes and the source."""
        from sins_sim.units import ARCSEC, MICRO_G

        return {"gyro_weight_arcsec": (np.asarray(self.gyro_rad) / ARCSEC).tolist(),
                "accelerometer_weight_ug_s": (np.asarray(self.accel_m_s) / MICRO_G).tolist(),
                "axes_frd": np.asarray(self.axes).tolist(), "source": self.source}


def pulse_weight_of(x) -> float | None:
    """The pulse weight of one channel's increments ``x`` (N,), read off the values: the smallest step between
    their distinct values, where every value is a whole multiple of it (to :data:`PULSE_TOLERANCE` of a pulse);
    None where they are not (an unquantised channel) or take a single value (no step to read)."""
    u = np.unique(np.asarray(x, dtype=np.float64))
    if u.size < 2:
        return None
    q = float(np.min(np.diff(u)))
    scale = float(np.max(np.abs(u)))
    if not (q > 0.0 and q > 1e3 * np.finfo(float).eps * scale):
        return None
    k = u / q
    k_max = float(np.max(np.abs(k)))
    if PULSE_TOLERANCE * k_max > MAX_PULSE_SLACK:
        return None     # a step of float rounding, not a pulse: the tolerance would pass any value as whole
    return q if float(np.max(np.abs(k - np.round(k)))) <= PULSE_TOLERANCE * max(1.0, k_max) else None


def quantise_pulses(x_frd, weights, axes, rng) -> np.ndarray:
    """Increments ``x_frd`` (N, 3) (body FRD) as a pulse readout outputs them (module docstring).

    Each log channel ``i`` (``x_log = x_frd axes^T``) with a non-zero weight ``w_i`` emits ``floor(r + x / w_i)``
    pulses per interval, the residue ``r`` carried (:func:`sins_sim._kernels.sensors.pulse_quantise`), starting
    uniform in ``[0, 1)`` from ``rng``; the pulses times the weights are turned back to FRD (``axes`` orthonormal).
    """
    from sins_sim._kernels.sensors import pulse_quantise

    c = np.asarray(axes, dtype=np.float64)
    w = np.asarray(weights, dtype=np.float64)
    x_log = np.asarray(x_frd, dtype=np.float64) @ c.T
    on = w != 0.0
    frac = rng.uniform(0.0, 1.0, 3)
    pulses = np.empty_like(x_log)
    pulse_quantise(np.ascontiguousarray(x_log / np.where(on, w, 1.0)), frac, pulses)
    out = np.where(on, pulses * w, x_log)
    return out @ c


@dataclass
class RestRun:
    """One run of the mission at rest (module docstring).

    Attributes
    ----------
    allan : dict
        ``(sensor, axis) -> AllanCurve`` (SI deviation).
    lines : dict
        ``(sensor, axis) -> LineSearch`` (the PSD, its floor and its lines).
    alignment : AlignmentResult
    nav_t_s : ndarray
        Times of the navigation rows from the start of navigation (s).
    nav : dict
        ``position_m`` (M, 3) north, east, up displacement; ``velocity_m_s`` (M, 3) NED; ``attitude_rad``
        (M, 3) rotation from the aligned start about north, east, down.
    """

    allan: dict
    lines: dict
    alignment: object
    nav_t_s: np.ndarray
    nav: dict = field(default_factory=dict)


def gyro_wander_sigma(sensors, window_s: float) -> float:
    """The gyros' bias wander averaged over a window (:func:`sins_sim.navigation.alignment.mean_bias_wander_sigma`)
    for the twin's ``sensors`` (:class:`~sins_sim.models.sensor_errors.SensorErrorParams`): each axis's rate random
    walk and bias instability (its Gauss-Markov sum, :func:`~sins_sim.models.sensor_errors.bias_instability_components`,
    the twin's own model of it), the RMS over the three axes (the east axis is a mix of them)."""
    from sins_sim.models.sensor_errors import FLICKER_FLOOR_FACTOR, bias_instability_components
    from sins_sim.navigation.alignment import mean_bias_wander_sigma
    from sins_sim.units import DEG_PER_H

    g = sensors.gyro
    per_axis = []
    for i in range(3):
        k = float(g.rrw_deg_h_rt_h[i]) * DEG_PER_H / 60.0
        floor = float(g.bias_instability_deg_h[i]) * DEG_PER_H * FLICKER_FLOOR_FACTOR
        tc, q = bias_instability_components(floor, g.bias_instability_tau_s) if floor > 0.0 else ((), ())
        per_axis.append(mean_bias_wander_sigma(window_s, k, tc, q))
    return float(np.sqrt(np.mean(np.square(per_axis))))


def align_at_rest(dth, dv, dt_s: float, site: dict, method: str, *, gyro_bias_sigma_rad_s: float,
                  accel_bias_sigma_m_s2: float, gyro_wander_sigma_rad_s: float = 0.0):
    """The self-alignment of a record at rest over its whole length (``coarse`` or ``inertial``), its stated sigma
    with the gyros' bias wander over the window (``gyro_wander_sigma_rad_s``, :func:`gyro_wander_sigma`).

    Raises
    ------
    ValueError
        An unknown method, or the alignment's own refusal (e.g. the unit not at rest).
    """
    from sins_sim.navigation.alignment import align_coarse, align_inertial

    if method not in ALIGNMENT_AT_REST:
        raise ValueError(f"alignment: must be one of {list(ALIGNMENT_AT_REST)}, got {method!r}")
    if method == "coarse":
        return align_coarse(dth, dv, dt_s, site["lat_rad"], gyro_bias_sigma_rad_s=gyro_bias_sigma_rad_s,
                            accel_bias_sigma_m_s2=accel_bias_sigma_m_s2, gyro_wander_sigma_rad_s=gyro_wander_sigma_rad_s)
    return align_inertial(dth, dv, dt_s, site["lat_rad"], site["height_m"], gyro_bias_sigma_rad_s=gyro_bias_sigma_rad_s,
                          accel_bias_sigma_m_s2=accel_bias_sigma_m_s2, gyro_wander_sigma_rad_s=gyro_wander_sigma_rad_s)


def rest_run(t_s, dth, dv, site: dict, method: str, *, gyro_bias_sigma_rad_s: float, accel_bias_sigma_m_s2: float,
             false_alarm: float, alignment=None, gyro_wander_sigma_rad_s: float = 0.0) -> RestRun:
    """Run the mission at rest on one record (module docstring).

    Parameters
    ----------
    t_s, dth, dv : ndarray
        End time of each interval (s), angle (rad) and velocity (m/s) increments (N, 3), evenly spaced.
    site : dict
        ``lat_rad``, ``lon_rad``, ``height_m``.
    method : str
        ``coarse`` or ``inertial``.
    gyro_bias_sigma_rad_s, accel_bias_sigma_m_s2 : float
        The alignment's bias priors.
    gyro_wander_sigma_rad_s : float
        The gyros' bias wander over the record (:func:`gyro_wander_sigma`), in the alignment's stated sigma.
    false_alarm : float
        Per channel, the chance of one or more false lines (:func:`~sins_sim.navigation.spectral_lines.find_lines`).
    alignment : AlignmentResult, optional
        An alignment already made on this record (else made here).
    """
    from sins_sim.navigation.allan import allan_deviation
    from sins_sim.navigation.attitude import attitude_error
    from sins_sim.navigation.spectral_lines import find_lines
    from sins_sim.simulation.external import navigate_free

    t = np.asarray(t_s, dtype=np.float64)
    dt = float(t[1] - t[0])
    fs = 1.0 / dt
    allan, lines = {}, {}
    for sensor, inc in zip(SENSORS, (dth, dv)):
        x = np.asarray(inc, dtype=np.float64) / dt
        for i, ax in enumerate("xyz"):
            col = x[:, i] - x[:, i].mean()
            allan[(sensor, ax)] = allan_deviation(col, fs)
            lines[(sensor, ax)] = find_lines(col, fs, false_alarm=false_alarm, increment_dt=dt)
    if alignment is None:
        alignment = align_at_rest(dth, dv, dt, site, method, gyro_bias_sigma_rad_s=gyro_bias_sigma_rad_s,
                                  accel_bias_sigma_m_s2=accel_bias_sigma_m_s2,
                                  gyro_wander_sigma_rad_s=gyro_wander_sigma_rad_s)
    free = navigate_free(t, dth, dv, site["lat_rad"], site["lon_rad"], site["height_m"], alignment.q_nb,
                         np.zeros(3))
    sol = free.solution
    q0 = np.tile(np.asarray(alignment.q_nb, dtype=np.float64), (sol.q_nb.shape[0], 1))
    nav = {"position_m": free.displacement_m(), "velocity_m_s": np.asarray(sol.v_ned_m_s, dtype=np.float64),
           "attitude_rad": attitude_error(sol.q_nb, q0)}
    return RestRun(allan, lines, alignment, np.asarray(sol.t_s) - free.start["t_s"], nav)


def twin_increments(sensors, n: int, dt_s: float, site: dict, q_nb, seed: int, pulses: PulseWeights | None = None,
                    added=None) -> tuple:
    """``(t_s, dtheta, dv)`` of the twin at rest: ``n`` intervals of ``dt_s`` at the site, body attitude ``q_nb``.

    The exact increments at rest are ``C_bn w_ie^n dt`` and ``C_bn (0, 0, -g) dt`` (``g`` normal gravity at the
    site's latitude and height, :func:`sins_sim.earth.gravity_down`); the errors ``sensors``
    (:class:`~sins_sim.models.sensor_errors.SensorErrorParams`) are applied to them with ``seed``, then, with
    ``pulses``, the readout's pulse quantisation (:func:`quantise_pulses`, the residues drawn after the errors from
    the same seed). ``added``, an (n, 6) rate (rad/s) and specific force (m/s^2) that a candidate effect adds
    (:mod:`sins_sim.simulation.twin_effects`), enters as its interval mean times the interval, before the
    quantisation (the readout counts what the unit senses).
    """
    from sins_sim.earth import earth_rate_ned, gravity_down
    from sins_sim.navigation.attitude import dcm_from_quat

    c_nb = dcm_from_quat(np.asarray(q_nb, dtype=np.float64))
    w_b = c_nb.T @ earth_rate_ned(site["lat_rad"])
    f_b = c_nb.T @ np.array([0.0, 0.0, -gravity_down(site["lat_rad"], site["height_m"])])
    dth, dv = sensed_increments(sensors, np.tile(w_b * dt_s, (n, 1)), np.tile(f_b * dt_s, (n, 1)), dt_s, seed,
                                pulses, added)
    return np.arange(1, n + 1) * dt_s, dth, dv


def sensed_increments(sensors, ideal_dth, ideal_dv, dt_s: float, seed: int, pulses: PulseWeights | None = None,
                      added=None) -> tuple:
    """``(dtheta, dv)`` the twin senses from the exact increments ``ideal_dth``, ``ideal_dv`` (N, 3): the errors
    ``sensors`` (:class:`~sins_sim.models.sensor_errors.SensorErrorParams`) applied with ``seed``; ``added`` (N, 6)
    rate and specific force times ``dt_s``; then, with ``pulses``, the readout's quantisation
    (:func:`quantise_pulses`, the residues drawn after the errors from the same seed). At rest
    (:func:`twin_increments`) or on a trajectory (:mod:`sins_sim.simulation.twin_moving`)."""
    from sins_sim.models.sensor_errors import AccelErrors, GyroErrors

    rng = np.random.default_rng(seed)
    gyros = GyroErrors(sensors.gyro, rng, dt_s)
    accels = AccelErrors(sensors.accelerometer, rng, dt_s)
    dth = gyros.apply(np.asarray(ideal_dth, dtype=np.float64))
    dv = accels.apply(np.asarray(ideal_dv, dtype=np.float64))
    if added is not None:
        dth = dth + added[:, :3] * dt_s
        dv = dv + added[:, 3:] * dt_s
    if pulses is not None:
        dth = quantise_pulses(dth, pulses.gyro_rad, pulses.axes, rng)
        dv = quantise_pulses(dv, pulses.accel_m_s, pulses.axes, rng)
    return dth, dv


def twin_runs(sensors, t_s, site: dict, q_nb, method: str, seeds, *, pulses: PulseWeights | None = None,
              **kwargs) -> list:
    """:func:`rest_run` on the twin (:func:`twin_increments`, with the readout's ``pulses``) once per seed, on the
    log's time axis ``t_s``."""
    return [run for run, _, _ in seed_runs(sensors, t_s, site, q_nb, method, seeds, pulses=pulses, **kwargs)]


def checked_added(added, n: int):
    """``added`` (an effect added to the twin: rate and specific force, (n, 6)) as float64, or None; one line
    naming it where it is not a finite (n, 6) array."""
    if added is None:
        return None
    added = np.asarray(added, dtype=np.float64)
    if added.shape != (n, 6) or not np.all(np.isfinite(added)):
        raise ValueError(f"added: must be a finite ({n}, 6) array of rate and specific force, got shape {added.shape}")
    return added


def seed_runs(sensors, t_s, site: dict, q_nb, method: str, seeds, *, pulses: PulseWeights | None = None,
              added=None, **kwargs):
    """Yield ``(RestRun, dtheta, dv)`` per seed: :func:`twin_increments` (with ``pulses`` and ``added``) on the
    log's time axis ``t_s``, then :func:`rest_run` on them (the one loop of :func:`twin_runs` and
    :func:`sins_sim.simulation.twin_effects.twin_runs_with`)."""
    t = np.asarray(t_s, dtype=np.float64)
    dt = float(t[1] - t[0])
    for seed in seeds:
        _, dth, dv = twin_increments(sensors, t.size, dt, site, q_nb, int(seed), pulses, added)
        yield rest_run(t, dth, dv, site, method, **kwargs), dth, dv

