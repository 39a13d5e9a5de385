"""The physical ranges the models declare (issue 12, point 4), in a module that imports nothing heavy.

A value outside a RANGE is refused by the model with a ValueError naming the field; one outside a TYPICAL
band is legal but unusual and draws one warning. The YAML schemas (:mod:`sins_sim.config.imu`) use the same
numbers, and because this module imports neither numba nor scipy, a configuration file is checked against
them before the engine is imported: a wrong file fails in a fraction of a second. Each model re-exports
its own ranges (``sins_sim.models.suspension.K1_MAX`` is this ``K1_MAX``).
"""

from __future__ import annotations

from sins_sim.units import ARCSEC, PIEZO_V_MAX

__all__ = ["F0_RANGE_HZ", "F0_TYPICAL_HZ", "K1_MAX", "K2_RANGE_RAD", "K3_MAX", "K4_MAX_PER_RAD", "K4_MIN_PER_RAD",
           "LOSS_AMPLITUDE_RAD", "K5_RANGE_RAD_PER_V", "ZETA_MAX", "Q_RANGE", "AMPLITUDE_RANGE_ARCMIN",
           "AMPLITUDE_TYPICAL_ARCMIN", "V_MAX", "V_TYPICAL_MAX", "RATE_MAX_HZ", "PLANT_RATE_RANGE_HZ",
           "MIN_STEPS_PER_PERIOD", "QUANTUM_RANGE_RAD", "QUANTUM_REAL_RANGE_RAD", "NOISE_MAX_RAD", "MAX_NUMTAPS"]

# --- the suspension (sins_sim.models.suspension) --------------------------------------------------------
# A value outside a RANGE is refused with a ValueError naming the field; one outside a TYPICAL band is
# legal but unusual and draws one warning. The YAML schemas (sins_sim/config/imu.py) use the same numbers.
#
#: f0 (Hz). Mechanically dithered RLGs resonate at 100-1500 Hz (the paper's 28 cm gyro: 386 Hz; small
#: tactical gyros up to ~1.5 kHz): that is the usual band. Below 20 Hz the "dither" would sit inside the
#: vehicle's own motion band; above 5 kHz no flexure carries a laser block at arcminute amplitudes.
F0_RANGE_HZ = (20.0, 5000.0)
F0_TYPICAL_HZ = (100.0, 1500.0)
#: k1 (eq. 9 softening scale). The slope of Nonl tends to -k1 / (2 k2) at large deflection, so the
#: restoring term delta + Nonl(delta) keeps growing only while k1 < 2 k2 (checked too); the paper's
#: 1.75e-4 is 8 % of that. 0.1 bounds k1 on its own (a 10 % stiffness change is an extreme spring).
K1_MAX = 0.1
#: k2 (rad), the deflection at which eq. 9 sets in: the paper's 1.05e-3 rad (3.6 arcmin) is of the order
#: of the dither; 1e-6 rad (0.2 arcsec) to 0.1 rad (5.7 deg) covers any flexure.
K2_RANGE_RAD = (1e-6, 0.1)
#: k3 (eq. 10 hysteretic loss): 1/Q = k3 (1 + k4 a); metal flexures have loss factors of 1e-4..1e-2
#: (the paper: 4.4e-3, Q = 187 at 3 arcmin). 0.2 (Q = 5) is a suspension that barely resonates.
K3_MAX = 0.2
#: k4 (1/rad), eq. 10's amplitude dependence: the paper's 250 /rad doubles the loss at 14 arcmin;
#: 1e4 /rad would multiply it by 90 at 30 arcmin. It is bounded below by the loss rule (LOSS_AMPLITUDE_RAD).
K4_MAX_PER_RAD = 1.0e4
#: The loss rule: 1/Q(a) = k3 (1 + k4 a) + 2 zeta must stay in (0, 1) for every deflection a up to 0.05 rad
#: (172 arcmin; beyond it a deflection is unphysical in this model: the correcting filter's D_LIMIT_RAD).
#: A negative loss pumps energy into the suspension and a loss above 1 is no resonance: with either, eq. 5,
#: which inverts eq. 10 on its own deflection estimate, runs away to inf (found by tests/test_properties.py:
#: k3 = 0.17, k4 = -9200 /rad, Q = 8 at the dither, NaN within 0.2 s). Hence k4 >= -1 / 0.05 = -20 /rad.
LOSS_AMPLITUDE_RAD = 0.05
K4_MIN_PER_RAD = -1.0 / LOSS_AMPLITUDE_RAD
#: |k5| (rad/V), eq. 14 piezo gain: a stack deflects the suspension by 1e-7..1e-4 rad per volt at DC (the
#: paper: 1.2e-5). Outside 1e-9..1e-2 the drive voltage for any dither is absurd (1e-30 asked for a
#: 1e25 V drive); the drive voltage itself is checked in sins_sim.models.drive (<= 1000 V).
K5_RANGE_RAD_PER_V = (1e-9, 1e-2)
#: zeta, the extra viscous damping ratio: 0.1 alone gives Q = 5 (see K3_MAX).
ZETA_MAX = 0.1
#: Mechanical Q at the dither amplitude: RLG dither suspensions have Q of 50-1000; below 5 it is no
#: resonance (the drive at F(a) and eq. 5's notch lose their meaning), above 1e6 the dither would take
#: Q / (pi f0) > 10 min to settle at 500 Hz. Checked where the amplitude is known (DriveParams.resolve).
Q_RANGE = (5.0, 1.0e6)

# --- the drive (sins_sim.models.drive) -------------------------------------------------------------------
#: Dither amplitude a_m (arcmin). RLG dithers run at 0.1-30 arcmin (the paper: 3 arcmin, a peak rate of
#: ~130 deg/s, far above the lock-in band): the usual band, outside it a warning. Below 0.01 arcmin
#: (0.6 arcsec, a few readout quanta) there is no dither to remove; above 60 arcmin (1 deg) the flexure
#: would be far beyond its elastic range and eq. 9/10 beyond their domain.
AMPLITUDE_RANGE_ARCMIN = (0.01, 60.0)
AMPLITUDE_TYPICAL_ARCMIN = (0.1, 30.0)
#: Drive voltage amplitude V_m (V): piezo stacks are rated to 100-200 V (low-voltage stacks) and up to
#: ~1000 V (high-voltage stacks). Above V_TYPICAL_MAX a warning, above V_MAX refused: the suspension's k5
#: (rad/V) or the amplitude is then wrong (k5 = 1e-30 asked for 1.25e25 V).
V_MAX = PIEZO_V_MAX  # 1000 V, shared with the recording reader (a recorded drive beyond it is refused there)
V_TYPICAL_MAX = 200.0
#: DAC, plant and readout rates (Hz): at most 1 MHz (14 x the paper's 72 kHz). The engine holds one 1 s chunk
#: at the plant rate in memory per axis (~20 float64 per step: 160 MB at 1 MHz).
RATE_MAX_HZ = 1.0e6

# --- the plant (sins_sim.models.plant) -------------------------------------------------------------------
#: Plant rate (Hz). At least 1 kHz; at most 1 MHz (14 x the paper's 72 kHz): the engine keeps one 1 s chunk
#: at the plant rate in memory per axis (~20 float64 per step, 160 MB at 1 MHz) and a second costs ~0.2 s of
#: CPU per axis there.
PLANT_RATE_RANGE_HZ = (1.0e3, 1.0e6)
#: Plant steps per period of the small-amplitude resonance f0. The integrators locate the turning points
#: of eq. 10 inside a step and the exact one propagates the oscillator exactly, but the drive is held over
#: a step and eq. 9/10 are sampled per step: at 72 kHz (48 steps per period of a 1.5 kHz motion) the exact
#: integrator agrees with RK4 at 288 kHz within 0.003 arcsec RMS (tests/test_plant_exact.py). 40 steps keep
#: the whole 100-1500 Hz band of dither suspensions on the default 72 kHz plant.
MIN_STEPS_PER_PERIOD = 40

# --- the readout (sins_sim.models.readout) ---------------------------------------------------------------
#: Readout quantum q (rad): one fringe is 1.2-6 arcsec for 10-50 cm cavities (2.42 arcsec at 28 cm) and
#: interpolators split it into up to 1/256, so real readouts lie in 0.001-60 arcsec (QUANTUM_REAL_RANGE_RAD, what
#: the YAML files accept). The library goes down to 1e-15 rad for "unquantised" references (the reproduction
#: uses 1e-13 rad): the int64 counts floor(phi / q) still hold block angles up to 9e3 rad.
QUANTUM_RANGE_RAD = (1e-15, 60.0 * ARCSEC)
QUANTUM_REAL_RANGE_RAD = (0.001 * ARCSEC, 60.0 * ARCSEC)
#: White readout noise before quantisation (rad): at most 60 arcsec RMS (25 fringes).
NOISE_MAX_RAD = 60.0 * ARCSEC
#: Sampling rates (Hz): at most RATE_MAX_HZ = 1 MHz, the drive's (see PLANT_RATE_RANGE_HZ).
#: Anti-alias taps: at most 1001 (a 500-sample delay, 7 ms at 72 kHz; the paper's FIR has 21).
MAX_NUMTAPS = 1001
