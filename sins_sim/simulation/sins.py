"""The engine: three dithered gyro channels, their filters, accelerometers and the strapdown loop.

One run is a pure function of (configuration, mission, duration, seed) and streams in chunks
(memory does not grow with the duration). Per chunk:

1. the mission truth (:class:`~sins_sim.simulation.truth.MissionTruth`: vehicle on the Earth,
   the chassis' motion profiles) gives each gyro's angle and rate at the plant rate, and the
   navigation truth, ideal gyro increments and accelerometer increments at the filter rate;
2. the unit (:class:`~sins_sim.simulation.unit.SensorUnit`: the sensor block, rigid or on its
   isolators, carrying three channels) takes the chunk: each axis (docs/user-guide/block.md: its own
   suspension, drive, readout, eq. 5 in both forms and eliminator) runs in fused
   kernels (:class:`~sins_sim.simulation.channel.ChannelChain`), the three suspensions stepped
   side by side, with the block when it is a body (:class:`~sins_sim.simulation.unit.SideBySide`),
   or the axes on threads; the block's own motion then amends the truth;
3. every filter's output is differenced into angle increments and navigated by its own
   :class:`~sins_sim.navigation.strapdown.StrapdownNavigator`, all fed by the same
   accelerometers, and compared with the truth (:mod:`~sins_sim.simulation.metrics`).

Filters compared (docs/theory/navigation.md): ``ideal`` (the true increments through
the same navigation: the algorithm's floor), ``raw`` (the decimated readout, dither
included), ``eliminator``, ``correcting`` (eq. 5, unity DC), ``correcting_paper`` (eq. 5 as
printed).

Time alignment. Filter output ``k`` describes the gyro angle at ``t_k - d`` with ``d`` a whole
number of filter samples: the anti-alias FIR's delay, plus one sample for eq. 5, or plus the
eliminator's DC group delay (rounded; the rounding residual is reported). Each filter's
navigation runs on the truth timeline ``j = k - d`` and starts aligned to the truth at
``start_s``; the first increment starts from the filter's mean offset from the truth over the
alignment window ``align_s`` (a single sample would carry its residual in as a tilt). ``accel_delay="matched"`` delays the accelerometers by the same ``d`` (what a
real unit does); ``"none"`` feeds them undelayed, so that the navigation mixes gyro data
``d`` samples old with current accelerometer data (the cost shows under vibration as a
sculling-like error).

Divergence. A filter whose output or navigation solution stops being finite, or whose navigation
error leaves the physical limits (attitude :data:`DIVERGED_ATTITUDE_RAD`, velocity
:data:`DIVERGED_VELOCITY_M_S`, position :data:`DIVERGED_POSITION_M`), is reported as diverged
(filter, axis, time, reason) and dropped; the run goes on for the others.

Three-axis plug-ins (:data:`sins_sim.filters.registry.THREE_AXIS`, e.g. ``lms_stripper``) read the
three readouts and the three dither pickoffs together: each axis also returns its deflection at
the filter rate (through an anti-alias chain identical to the readout's), the pickoff model
(:class:`~sins_sim.models.pickoff.PickoffTriad`, the unit's ``pickoff`` with its cross-coupling,
sampled at the filter rate) turns the three into voltages, and the filter runs on this thread
once the chunk's three axes are in.
"""

from __future__ import annotations

import math
import dataclasses
import warnings
from dataclasses import dataclass, field

import numpy as np

from sins_sim import _validate as v
from sins_sim.models.accelerometer import Accelerometer, AccelerometerParams
from sins_sim.models.block import BlockParams
from sins_sim.models.pickoff import PickoffTriad, PickoffTriadParams
from sins_sim.models.sensor_errors import AccelErrors, GyroErrors, SensorErrorParams
from sins_sim._kernels import series as kseries
from sins_sim._kernels import truth as ktruth
from sins_sim._kernels.strapdown import OUT_H, OUT_LAT, OUT_LON, OUT_Q, OUT_V
from sins_sim.filters import registry as filter_registry
from sins_sim.navigation.coning import CONING_ALGORITHMS
from sins_sim.simulation.responses import tuned_design
from sins_sim.navigation.attitude import attitude_error
from sins_sim.navigation.strapdown import StrapdownNavigator
from sins_sim.simulation.aiding import AidedMission, AidingSettings
from sins_sim.simulation.aligning import AlignmentAccumulator, AlignmentSettings
from sins_sim.simulation.channel import ChannelConfig, DriveControl
from sins_sim.simulation.metrics import N_COLS, ErrorSeries, NavErrorStats
from sins_sim.simulation.truth import MissionTruth
from sins_sim.simulation.unit import AXES, SensorUnit, run_channels

#: The coning/sculling choice whose coefficients are designed per filter (issue 28).
TUNED = "filter_tuned"
#: Every coning/sculling choice of a run.
NAV_ALGORITHMS = CONING_ALGORITHMS + (TUNED,)

__all__ = ["DriveControl", "ImuConfig", "NavSettings", "SinsResult", "simulate_sins", "SINS_FILTERS", "DEFAULT_FILTERS",
           "default_threads"]

#: The built-in filters a SINS run can compare (plug-ins of :mod:`sins_sim.filters.registry` come on top).
SINS_FILTERS = filter_registry.BUILTIN_FILTERS
#: The filters navigated by default: the dither filters and the ideal floor (``raw``, the readout with the
#: dither still in it, on request).
DEFAULT_FILTERS = filter_registry.DEFAULT_FILTERS
#: Default rate of the stored error series (Hz) and the most blocks stored per filter by default.
DEFAULT_SERIES_RATE_HZ = 10.0
MAX_SERIES_BLOCKS = 7200
#: An attitude error beyond this (rad) means the navigation of a filter has diverged.
DIVERGED_ATTITUDE_RAD = 0.5
#: A velocity error beyond this (m/s) means the navigation has diverged: the first cosmic velocity
#: ``sqrt(GM / R) = sqrt(3.986004e14 / 6.371e6) = 7.91 km/s`` (GM: WGS 84; R: the Earth's mean radius, IUGG), the speed
#: of a circular orbit at the surface. A solution that far off would orbit the Earth: the mechanization's assumptions (a
#: vehicle near the surface: its gravity model, transport rate and Schuler loop) no longer describe it, and its
#: errors are no longer navigation errors. (A consumer-MEMS accelerometer bias at the bound of the sensor ranges,
#: 0.2 g, needs 4000 s of free inertial navigation to get there.)
DIVERGED_VELOCITY_M_S = 7.91e3
#: A horizontal or height error beyond this (m) means the navigation has diverged: the Earth's mean radius (IUGG,
#: 6371 km), one radian of arc; a solution that far from the vehicle has lost every information about where it is.
DIVERGED_POSITION_M = 6.371e6


def divergence_reason(row) -> str:
    """Why the navigation error ``row`` (columns of :func:`sins_sim._kernels.truth.nav_errors`) counts as diverged.

    Returns the first limit the row breaks, stated with its threshold (:data:`DIVERGED_ATTITUDE_RAD`,
    :data:`DIVERGED_VELOCITY_M_S`, :data:`DIVERGED_POSITION_M`), or ``"not finite"``.
    """
    row = np.asarray(row, dtype=np.float64)
    if not np.all(np.isfinite(row[:10])):
        return "navigation solution diverged (not finite)"
    att = float(np.linalg.norm(row[7:10]))
    if att > DIVERGED_ATTITUDE_RAD:
        return f"navigation solution diverged (attitude error {att:.3g} rad beyond {DIVERGED_ATTITUDE_RAD} rad)"
    vel = float(np.linalg.norm(row[4:7]))
    if vel > DIVERGED_VELOCITY_M_S:
        return (f"navigation solution diverged (velocity error {vel:.3g} m/s beyond {DIVERGED_VELOCITY_M_S:g} m/s, "
                "the first cosmic velocity)")
    pos = max(float(row[2]), abs(float(row[3])))
    return (f"navigation solution diverged (position error {pos:.3g} m beyond {DIVERGED_POSITION_M:g} m, the "
            "Earth's radius)")
#: Allan records (gyro-angle and velocity error at sample instants): at most this rate (Hz) and at most this many
#: samples per axis and filter (10 min at 100 Hz, 1 h at 18 Hz; 1.6 MB per filter), so that memory, and the transient
#: arrays of the Allan analysis at the end, stay flat in the mission length.
ALLAN_RATE_HZ = 100.0
ALLAN_MAX_SAMPLES = 2 ** 16
#: Shortest Allan record analysed (samples): below it the curve has too few clusters to read a term.
ALLAN_MIN_SAMPLES = 200
#: The vehicle counts as at rest (for the Allan analysis) below this true speed (m/s), well below any deliberate
#: motion ...
REST_SPEED_M_S = 0.05
#: ... of the velocity averaged over this window (s), so that the block's vibration does not count as motion.
REST_WINDOW_S = 1.0
#: An Allan record whose RMS, once a line is removed, is below this (rad or m/s) holds only rounding: no noise term.
#: (1e-10 rad is 2e-5 arcsec, a thousandth of the smallest readout quantum in use.)
ALLAN_NOISE_FLOOR = 1e-10


@dataclass(frozen=True)
class ImuConfig:
    """The unit: three gyro channels on orthogonal axes x, y, z, their drive control, the accelerometers.

    Parameters
    ----------
    channels : tuple of three ChannelConfig
        Axes x, y, z; resonances must differ, plant and filter rates must agree.
    drive_control : DriveControl
        Amplitude control of the three drives (closed loop by default).
    accelerometer : AccelerometerParams
        The accelerometer triad.
    name : str
        A label for reports.
    sensors : SensorErrorParams or None
        Gyro and accelerometer errors beyond the dither physics (bias, noise, scale factor,
        misalignment; :mod:`sins_sim.models.sensor_errors`); None: ideal sensors.
    effects : tuple of Effect
        Catalogue effects (:mod:`sins_sim.models.effects`) acting in the engine as in recordings
        (:class:`~sins_sim.simulation.channel.ChannelChain`); each names its axes among x, y, z
        (none: all three). ``axis_coupling`` is refused (see
        :func:`~sins_sim.simulation.channel.check_engine_effects`).
    block : BlockParams or None
        The sensor block as a body on its isolators (:mod:`sins_sim.models.block`,
        docs/user-guide/block.md): the three suspensions load it and feel its
        motion. None: the rigid block whose motion is prescribed (today's model).
    pickoff : PickoffTriadParams
        The three dither pickoffs and their cross-coupling, read by three-axis plug-ins
        (``lms_stripper``). Each coil's ``noise_v`` is per sample at the plant rate; the engine reads
        the coils once per filter sample (``rate_hz`` replaced by the filter rate), the average of
        ``decimation`` plant-rate samples, whose noise is ``noise_v / sqrt(decimation)``.
    filter_settings : dict
        Plug-in name -> mapping of its settings (the IMU file's section of that name, e.g.
        ``lms_stripper``), handed to three-axis plug-ins in their context.
    """

    channels: tuple
    drive_control: DriveControl = field(default_factory=DriveControl)
    accelerometer: AccelerometerParams = field(default_factory=AccelerometerParams)
    name: str = "imu"
    sensors: SensorErrorParams | None = None
    effects: tuple = ()
    block: BlockParams | None = None
    pickoff: PickoffTriadParams = field(default_factory=PickoffTriadParams)
    filter_settings: dict = field(default_factory=dict)

    def __post_init__(self):
        from sins_sim.simulation.channel import check_engine_effects

        if not isinstance(self.pickoff, PickoffTriadParams):
            raise ValueError(f"imu.pickoff: must be PickoffTriadParams, got {type(self.pickoff).__name__}")

        object.__setattr__(self, "effects", check_engine_effects(self.effects))
        for e in self.effects:
            e.check_axes(AXES)
        if len(self.channels) != 3 or not all(isinstance(c, ChannelConfig) for c in self.channels):
            raise ValueError("imu.channels: must be three ChannelConfig (x, y, z)")
        rates = {(c.plant.rate_hz, c.readout.output_rate_hz) for c in self.channels}
        if len(rates) != 1:
            raise ValueError(f"imu.channels: all axes must share plant and filter rates, got {sorted(rates)}")
        f0 = [c.suspension.f0_hz for c in self.channels]
        if len(set(f0)) < 3:
            raise ValueError(
                f"imu.channels: the three resonances must differ so the dithers do not lock together "
                f"(docs/user-guide/block.md), got {f0}"
            )

    @property
    def plant_rate_hz(self) -> float:
        return self.channels[0].plant.rate_hz

    @property
    def filter_rate_hz(self) -> float:
        return self.channels[0].readout.output_rate_hz


#: The navigation update rate of a mission (Hz) when the scenario sets neither ``navigation.rate_hz`` nor
#: ``n_sub`` (issue 26): the coning and sculling sums run at the filter rate, attitude, velocity and position
#: update at about this rate, as in real strapdown systems (100-400 Hz, Savage 1998 Parts 1 and 2). 400 Hz is
#: the top of that range: at 7.2 kHz (18 filter samples per update) its error against the full-rate solution is
#: below 1e-5 arcsec under a 600 Hz cone and 2e-5 m/s after 10 s (``tests/test_multirate.py``), far below every
#: filter's own error, while the navigators cost a fifth of what they cost at every filter sample.
DEFAULT_NAV_RATE_HZ = 400.0


def default_n_sub(filter_rate_hz: float) -> int:
    """Filter samples per navigation update of a mission by default: the whole number nearest to
    ``filter_rate_hz / DEFAULT_NAV_RATE_HZ``, at least 1 (18 at 7.2 kHz: 400 Hz)."""
    return max(1, int(round(filter_rate_hz / DEFAULT_NAV_RATE_HZ)))


@dataclass(frozen=True)
class NavSettings:
    """Navigation settings of a run.

    Parameters
    ----------
    coning, sculling : {"none", "two_sample", "three_sample", "four_sample", "filter_tuned"}
        Coning and sculling compensation (:class:`~sins_sim.navigation.strapdown.StrapdownNavigator`);
        ``filter_tuned``: coefficients designed for each filter's increments over ``tuned_band_hz``
        (:func:`sins_sim.simulation.responses.tuned_design`; sculling takes the same coefficients by
        the coning/sculling duality, exact when the accelerometers see the gyros' response).
    start_s : float
        Navigation starts, aligned to the truth, at this time (s), after the dithers have
        built up from rest.
    n_sub : int
        Filter samples per navigation update (the coning/sculling sums run at the filter rate). 1 here
        (every filter sample); a scenario's default is :func:`default_n_sub` (400 Hz).
    vertical : {"height_aid", "free"}
        Vertical channel: held by a height aid (the truth height through the third-order loop)
        or free (pure inertial, unstable with a time constant of about 570 s).
    height_aid_tau_s : float
        Time constant of the height-aided loop (s).
    accel_delay : {"matched", "none"}
        Whether the accelerometers are delayed to match each filter's gyro delay.
    align_s : float
        Alignment window before ``start_s`` (s): each filter's gyro-angle offset from the truth is
        averaged over it and taken as the reference of the first increment, as a fine alignment
        averages its sensors (0: the single sample at ``start_s``, whose residual then enters the
        run as an initial tilt).
    timeseries_rate_hz : float or None
        Rate of the stored (block-averaged, min/max enveloped) error series (Hz). None: 10 Hz, or
        slower for long missions so that at most :data:`MAX_SERIES_BLOCKS` blocks are stored (the
        stored series, and the memory they take, do not grow with the mission length; every block
        keeps its min/max envelope).
    spectrum_s : float
        Length of the full-rate gyro-error record kept for spectra (s, from ``start_s``).
    tuned_band_hz : (float, float) or None
        Design band of ``filter_tuned`` (Hz), required with it.
    designs : dict or None
        Per filter name the filter-tuned design (:func:`~sins_sim.simulation.responses.tuned_design`);
        None: computed by :func:`simulate_sins` when ``filter_tuned`` is chosen.
    alignment : AlignmentSettings
        How each filter's navigation finds its starting attitude (:mod:`sins_sim.simulation.aligning`):
        ``truth`` (the default) starts from the true attitude with the offset averaging of ``align_s``;
        another method aligns from the filter's own increments over ``alignment.duration_s`` before
        ``start_s`` and starts from what it finds, with zero velocity.
    aiding : AidingSettings or None
        GNSS aiding (:mod:`sins_sim.simulation.aiding`): each filter's increments also navigated by the
        error-state filter with the same fixes; None: free navigation only.
    """

    coning: str = "two_sample"
    sculling: str = "two_sample"
    start_s: float = 1.0
    n_sub: int = 1
    vertical: str = "height_aid"
    height_aid_tau_s: float = 100.0
    accel_delay: str = "matched"
    align_s: float = 0.5
    timeseries_rate_hz: float | None = None
    spectrum_s: float = 2.0
    tuned_band_hz: tuple | None = None
    designs: dict | None = field(default=None, compare=False)  # derived from the settings and the unit
    alignment: AlignmentSettings = field(default_factory=AlignmentSettings)
    aiding: AidingSettings | None = None

    def __post_init__(self):
        v.choice("navigation", "coning", self.coning, NAV_ALGORITHMS)
        v.choice("navigation", "sculling", self.sculling, NAV_ALGORITHMS)
        if self.tuned:
            band = self.tuned_band_hz
            if band is None or len(band) != 2 or not (0.0 < float(band[0]) < float(band[1])):
                raise ValueError(f"navigation.tuned_band_hz: must be [low, high] with 0 < low < high (the design "
                                 f"band of filter_tuned, required with it), got {band!r}")
        v.non_negative("navigation", "start_s", self.start_s)
        if isinstance(self.n_sub, bool) or int(self.n_sub) != self.n_sub or self.n_sub < 1:
            raise ValueError(f"navigation.n_sub: must be an integer >= 1, got {self.n_sub!r}")
        v.choice("navigation", "vertical", self.vertical, ("height_aid", "free"))
        v.positive("navigation", "height_aid_tau_s", self.height_aid_tau_s)
        v.choice("navigation", "accel_delay", self.accel_delay, ("matched", "none"))
        v.non_negative("navigation", "align_s", self.align_s)
        v.non_negative("navigation", "spectrum_s", self.spectrum_s)
        if self.timeseries_rate_hz is not None:
            v.positive("navigation", "timeseries_rate_hz", self.timeseries_rate_hz)
        if not isinstance(self.alignment, AlignmentSettings):
            raise ValueError(f"navigation.alignment: must be an AlignmentSettings, got {type(self.alignment).__name__}")
        if self.alignment.active and self.alignment.duration_s > self.start_s:
            raise ValueError(f"navigation.alignment.duration_s: the alignment window ends at the navigation start, "
                             f"so it must be <= start_s = {self.start_s:g} s, got {self.alignment.duration_s:g}; "
                             f"set navigation.start_s >= {self.alignment.duration_s + 1.0:g}")

    @property
    def tuned(self) -> bool:
        """Whether coning or sculling is ``filter_tuned``."""
        return TUNED in (self.coning, self.sculling)

    def compensation(self, name: str):
        """``(coning, sculling)`` for the navigator of filter ``name``: names, or the tuned coefficients."""
        def one(choice):
            return self.designs[name]["coefficients"] if choice == TUNED else choice
        return one(self.coning), one(self.sculling)

    def series_rate_hz(self, duration_s: float) -> float:
        """The stored series' rate for a mission of ``duration_s`` (see ``timeseries_rate_hz``)."""
        if self.timeseries_rate_hz is not None:
            return self.timeseries_rate_hz
        return min(DEFAULT_SERIES_RATE_HZ, MAX_SERIES_BLOCKS / max(duration_s - self.start_s, 1e-9))


@dataclass
class SinsResult:
    """What a SINS run produced (SI units, rad).

    Attributes
    ----------
    stats : dict name -> NavErrorStats
        Full-rate error statistics per filter (navigation runs only).
    series : dict name -> dict of ndarray
        Stored error series per filter (:meth:`ErrorSeries.arrays`).
    truth_series : dict of ndarray
        The truth's ``t_s, lat_rad, lon_rad, h_m`` at the stored rate.
    spectra : dict
        ``t`` and per filter the gyro-angle error (output minus truth, rad, (N, 3)) at the
        filter rate over ``spectrum_s``.
    delays : dict name -> int
        Alignment shift in filter samples, and under ``residual_eliminator`` the fractional
        remainder per filter whose delay is not a whole number of samples (the eliminator's
        group delay, plug-ins).
    diverged : dict name -> dict
        Filters whose output or navigation stopped being finite: axis, time, reason.
    drives : list of dict
        Per axis: resonance, drive frequency, initial and final V_m, measured amplitude.
    outputs_last : dict name -> ndarray (3,)
        Last filter output per axis (rad), for checks.
    filter_rate_hz, duration_s, nav_start_s : float
        Filter rate (Hz), mission length and navigation start (s).
    warnings : list of str
        One line per distinct warning raised during the run (``"axis x: ..."``).
    filters : tuple of str
        The filters compared.
    nav : NavSettings or None
    allan : dict
        ``rate_hz``, ``record_s`` and per filter name (and ``accelerometers``) the Allan analyses of
        each axis (:func:`sins_sim.navigation.allan.allan_axes`) of the sensor error over the
        navigation period: the gyro-angle error (filter output minus the true gyro angle, sensor
        errors included) and the accumulated velocity-increment error of the accelerometers,
        sampled at ``rate_hz``. At rest this is the output's own noise; in motion the true motion
        is removed and what remains is the sensor's and the filter's error. Empty without
        navigation or when the record is shorter than :data:`ALLAN_MIN_SAMPLES`.
    records : dict
        The sampled sensor-level error records behind :attr:`allan` and the gyro drift
        (:func:`_error_records`): ``t_s``, ``rate_hz``, ``speed_m_s`` (the vehicle's true speed at each
        sample, its velocity averaged over :data:`REST_WINDOW_S`), and per filter (and ``accelerometers``) an ``(N, 3)`` array in body axes of the
        accumulated gyro-angle error (rad) or velocity-increment error (m/s). Empty without navigation.
    filter_reports : dict name -> dict
        What a plug-in reports about itself at the end (its ``report()``; e.g. ``lms_stripper``: the adapted
        gains, the convergence time, the divergence).
    block : dict or None
        With a block on isolators (``imu.block``): its own rotation relative to the chassis at the filter rate
        over the spectrum window (``navigation.spectrum_s`` from the navigation start; the first 2 s without
        navigation): ``t_s`` (N,), ``theta_rad`` (N, 3) about block axes x, y, z, ``rate_hz``, and the
        block's ``isolator_modes_hz`` with their ``isolator_damping`` (:meth:`BlockParams.isolator_modes`).
        None without a block.
    online : dict axis -> dict
        With ``filter_parameters: {source: online}``: per axis the estimator's ``history`` (one row per update: the
        estimate, its standard deviations, the values fed to the filters and the plant's truth,
        :meth:`sins_sim.simulation.online.OnlineLoop`) and its ``events`` (``(t_s, kind, message)``).
    alignments : dict name -> dict
        With ``navigation.alignment`` other than ``truth``: per filter the
        :class:`~sins_sim.navigation.alignment_result.AlignmentResult` (``result``) and its error against the
        true attitude at the navigation start (``error_rad``, psi in NED: north and east tilt, heading).
    aided : dict name -> dict
        With ``navigation.aiding``: per filter :meth:`sins_sim.simulation.aiding.AidedMission.finish` (``result``:
        the :class:`~sins_sim.navigation.aided.AidedResult` without its covariance matrices, ``errors`` (K, 9)
        against the truth, ``growth``: the outage growth, ``nees``, ``smoothed``, ``true_bias``), and
        ``"fixes"``: the :class:`~sins_sim.navigation.gnss.GnssFixes` every filter was given.
    """

    stats: dict
    series: dict
    truth_series: dict
    spectra: dict
    delays: dict
    diverged: dict
    drives: list
    filter_rate_hz: float
    duration_s: float
    nav_start_s: float
    warnings: list
    filters: tuple
    nav: NavSettings | None
    outputs_last: dict
    allan: dict = field(default_factory=dict)
    records: dict = field(default_factory=dict)
    filter_reports: dict = field(default_factory=dict)
    block: dict | None = None
    online: dict = field(default_factory=dict)
    alignments: dict = field(default_factory=dict)
    aided: dict = field(default_factory=dict)


def axis_pool(threads: int, n_axes: int = 3):
    """One single-thread executor per axis (each axis's chunks run in order), or None for serial.

    The kernels release the GIL, so the axes run in parallel while the calling thread prepares
    the next chunk's truth and navigates the previous one.
    """
    if threads <= 1:
        return None
    from concurrent.futures import ThreadPoolExecutor

    return [ThreadPoolExecutor(max_workers=1, thread_name_prefix=f"sins-axis-{AXES[i]}") for i in range(n_axes)]


def submit_axes(chains, i0, ang, rate, pool, three=None, worker=None, lin=None, base=None):
    """Start the three chains on one chunk: futures on ``pool`` (one thread per axis), or through
    ``three`` (a :class:`~sins_sim.simulation.unit.SideBySide`, when given) on ``worker`` (one
    thread) or deferred to this thread. ``lin``: the chassis' linear acceleration for a block's isolators;
    ``base``: the chassis' angle and rate without the profiles that enter at the block (:meth:`SideBySide.run`)."""
    if pool is None and three is not None:
        if worker is not None:
            return ("future", worker.submit(three.run, i0, ang, rate, lin, base))
        return ("three", three, i0, ang, rate, lin, base)
    if pool is None or any(ch.path != "fused" for ch in chains):
        return ("serial", i0, ang, rate)
    return ("futures", [pool[i].submit(ch.run_kernel, i0, np.ascontiguousarray(ang[:, i]),
                                       np.ascontiguousarray(rate[:, i])) for i, ch in enumerate(chains)])


def collect_axes(chains, job, caught):
    """The outputs of a chunk started by :func:`submit_axes`, with each axis's warnings collected.

    Warnings become ``"axis x: message"`` lines in ``caught``; the warning checks run in the
    calling thread (``warnings.catch_warnings`` is not thread-safe).
    """
    import warnings as _warnings

    outs = []
    if job[0] == "three":  # one thread: the three suspensions side by side
        _, runner, i0, ang, rate, lin, base = job
        outs = runner.run(i0, ang, rate, lin, base)
    elif job[0] == "serial":
        _, i0, ang, rate = job
        for i, ch in enumerate(chains):
            with _warnings.catch_warnings(record=True) as axis_w:
                _warnings.simplefilter("always")
                outs.append(ch.run(i0, np.ascontiguousarray(ang[:, i]), np.ascontiguousarray(rate[:, i])))
            caught.extend(f"axis {AXES[i]}: {w.message}" for w in axis_w)
        return outs
    elif job[0] == "future":
        outs = job[1].result()
    else:
        outs = [f.result() for f in job[1]]
    for i, ch in enumerate(chains):
        with _warnings.catch_warnings(record=True) as axis_w:
            _warnings.simplefilter("always")
            ch.check_chunk(outs[i])
        caught.extend(f"axis {AXES[i]}: {w.message}" for w in axis_w)
    return outs


def default_threads() -> int:
    """Threads for the axes of one run: the cores this process may use, at most 3."""
    import os

    try:
        n = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        n = os.cpu_count() or 1
    return max(1, min(3, n))


def stationary_vehicle(duration_s: float, lat_deg: float = 45.0, lon_deg: float = 0.0, height_m: float = 0.0,
                       heading_deg: float = 0.0):
    """A vehicle at rest at a site for ``duration_s`` (level, heading ``heading_deg``)."""
    from sins_sim.models.motion.trajectory import Stationary, Trajectory

    return Trajectory(math.radians(lat_deg), math.radians(lon_deg), height_m, 0.0, math.radians(heading_deg),
                      (Stationary(duration_s),))


class _Ring:
    """A sliding window of per-index rows ``[base, base + len)`` (filter-sample indices).

    Rows live in one preallocated buffer: a push writes behind the live rows, a drop moves the
    start; the live rows are moved to the front (or the buffer doubled) only when a push would
    run past its end. Views from :meth:`get` are valid until the next :meth:`push`.
    """

    def __init__(self, width, capacity=1024):
        self.base = 0
        self._buf = np.zeros((max(int(capacity), 16),) + tuple(width))
        self._off = 0  # buffer row of index base
        self._n = 0  # live rows

    @property
    def a(self):
        """The live rows (a view)."""
        return self._buf[self._off:self._off + self._n]

    def _room(self, m):
        """Make room for ``m`` rows behind the live ones; returns the buffer row to write at."""
        n = self._n
        if self._off + n + m > self._buf.shape[0]:
            if n + m > self._buf.shape[0]:
                buf = np.zeros((2 * (n + m),) + self._buf.shape[1:])
                buf[:n] = self._buf[self._off:self._off + n]
                self._buf = buf
            elif n:
                self._buf[:n] = self._buf[self._off:self._off + n].copy()
            self._off = 0
        return self._off + n

    def push(self, rows):
        m = rows.shape[0]
        i = self._room(m)
        self._buf[i:i + m] = rows
        self._n += m

    def push_columns(self, cols):
        """Push rows given as one 1-D array per column (the per-axis outputs, without stacking them)."""
        m = cols[0].shape[0]
        i = self._room(m)
        for c, x in enumerate(cols):
            self._buf[i:i + m, c] = x
        self._n += m

    def get(self, j0, j1, step=1):
        return self._buf[self._off:self._off + self._n][j0 - self.base:j1 - self.base:step]

    @property
    def end(self):
        return self.base + self._n

    def drop_before(self, j):
        k = j - self.base
        if k > 0:
            k = min(k, self._n)
            self._off += k
            self._n -= k
            self.base = j


class _FilterNav:
    """One filter's navigation: its increments and the accelerometers, aligned, through the strapdown."""

    def __init__(self, name, delay, dv_shift):
        self.name = name
        self.d = delay  # output index k describes truth index j = k - d
        self.dv_shift = dv_shift  # accelerometer index = j + dv_shift
        self.nav = None
        self.next_j = None  # next truth index to navigate
        self.j0 = None
        self.stats = NavErrorStats()
        self.series = None
        self.diverged = None
        self.free = np.zeros(6)  # free attitude error and the last gyro-angle error (see nav_errors)
        self.ref = None  # gyro angle the first increment starts from (alignment)
        self.epoch_j = None  # truth index of the last update (its interval's samples are kept from here on)
        self.prev_row = None  # the error row of the last update, and the between-epoch state (interval means)
        self.fast_state = np.zeros(9)
        self.aligner = None  # AlignmentAccumulator while the alignment window fills (navigation.alignment)
        self.align_next = None  # next truth index whose increment the aligner takes
        self.alignment = None  # {"result": AlignmentResult, "q_true": ...} once aligned
        self.aided = None  # the filter's aided run (navigation.aiding)
        self.aid_mission = None  # the mission's AidedMission, shared by the filters
        self.n_out = None  # filter samples of the run


def tuned_designs(imu: ImuConfig, filters, band_hz, key: str = "navigation.coning") -> dict:
    """The filter-tuned coning design of each filter (:func:`sins_sim.simulation.responses.tuned_design`).

    ``key`` is the setting that chose ``filter_tuned`` (``navigation.coning`` or ``navigation.sculling``), named
    when a filter cannot be designed for.

    A design that is ill-conditioned for its filter (it adds more residual over the whole band than it removes in
    its own: :func:`~sins_sim.simulation.responses.tuned_design`) is replaced by the two-sample coefficients, with
    one :class:`UserWarning` line naming ``key``, the filter and the numbers.

    Raises
    ------
    ValueError
        If the band reaches the filter Nyquist or a plug-in has no frequency response (the
        message names ``navigation.tuned_band_hz`` or ``navigation.coning``).
    """
    fs = imu.filter_rate_hz
    if not float(band_hz[1]) < 0.5 * fs:
        raise ValueError(f"navigation.tuned_band_hz: must stay below the filter Nyquist {0.5 * fs:g} Hz "
                         f"(readout.output_rate_hz / 2), got {list(band_hz)!r}")
    out = {}
    for name in filters:
        if filter_registry.is_known(name) and filter_registry.is_three_axis(name):
            raise ValueError(f"{key}: filter_tuned cannot go with the filter {name}: filter_tuned designs "
                             f"its coefficients from a single-axis filter's fixed frequency response, and {name} reads "
                             "the three axes together with no fixed response"
                             + (" (the LMS stripper adapts its gains as it runs)" if name == "lms_stripper" else "")
                             + ": choose another coning/sculling algorithm or leave it out of filters")
        try:
            out[name] = tuned_design(run_channels(imu), name, band_hz, fs)
        except ValueError as exc:
            raise ValueError(f"{key}: {exc}") from None
        if out[name]["fallback"]:  # ill-conditioned for this filter: it navigates with two_sample (one line)
            warnings.warn(f"{key}: {out[name]['reason']}", UserWarning, stacklevel=2)
    return out


def simulate_sins(imu: ImuConfig, motion, duration_s: float, seed: int = 0, nav: NavSettings | None = NavSettings(),
                  filters=DEFAULT_FILTERS, chunk_s: float = 1.0, progress=None, threads: int | None = None,
                  vehicle=None, translation=None, vibration_enters: str = "chassis",
                  motion_enters: str = "chassis") -> SinsResult:
    """Run the three-axis SINS (module docstring).

    Parameters
    ----------
    imu : ImuConfig
        The unit: three channels, drive control, accelerometers.
    motion : Motion3D
        The angular motion profiles relative to the vehicle (vibration, coning, shock...): the block's own, or with
        a block on isolators the chassis' or the block's (``motion_enters``).
    duration_s : float
        Mission length (s), > 0.
    seed : int
        Seed of every random stream of the run (readout noise per axis, amplitude modulation).
    nav : NavSettings or None
        Navigation settings; None runs the gyro chains and filters only (no truth attitude, no
        navigation): the engine's speed without the INS loop.
    filters : sequence of str
        Filters to navigate: built-in (:data:`SINS_FILTERS`) or plug-in names
        (:func:`sins_sim.filters.registry.plugin_names`); default :data:`DEFAULT_FILTERS`.
    chunk_s : float
        Chunk length (s): memory bound; results do not depend on it.
    progress : callable(fraction) or None
    threads : int or None
        Threads (None: :func:`default_threads`); results do not depend on it. One: the three
        suspensions stepped side by side in this thread. Several: with navigation the three side by
        side on one worker while this thread prepares the truth and navigates; without, one thread
        per axis.
    vehicle : trajectory or None
        The vehicle (``sins_sim.models.motion.trajectory``); None: at rest at 45 deg N, level,
        heading north.
    translation : translational vibration or None
        The linear vibration in vehicle axes (``accel``, ``velocity``, ``velocity_increment``).
    vibration_enters : {"chassis", "block"}
        With a block on isolators (``imu.block``): where ``translation`` enters. ``"chassis"``: it is the
        chassis' vibration and reaches the block through the isolators (base excitation; with the elastic centre
        off the c.g. it rocks the block); ``"block"``: it is the block's own (as without a block). Without a
        block it is the block's.
    motion_enters : {"chassis", "block"}
        With a block on isolators: where ``motion`` (the angular profiles) enters. ``"chassis"``: it rotates the
        chassis and the block follows through its isolators; ``"block"``: it is the block's own rotation as
        measured on it, and the block's response to the dither reactions and to what enters at the chassis is
        superposed (:func:`sins_sim.simulation.unit.block_base_excitation`). Without a block it is the block's.

    Returns
    -------
    SinsResult
    """
    duration_s = v.positive("run", "duration_s", duration_s)
    if vibration_enters not in ("chassis", "block"):
        raise ValueError(f"run.vibration_enters: must be 'chassis' or 'block', got {vibration_enters!r}")
    if motion_enters not in ("chassis", "block"):
        raise ValueError(f"run.motion_enters: must be 'chassis' or 'block', got {motion_enters!r}")
    filters = tuple(dict.fromkeys(filters))
    for name in filters:
        if not filter_registry.is_known(name):
            raise ValueError(f"run.filters: unknown filter {name!r}; known: "
                             f"{', '.join(SINS_FILTERS + filter_registry.plugin_names())}")
    plugins = tuple(n for n in filters if n not in SINS_FILTERS)
    plugins3 = tuple(n for n in plugins if filter_registry.is_three_axis(n))
    plugins = tuple(n for n in plugins if n not in plugins3)
    if nav is not None and nav.start_s >= duration_s:
        raise ValueError(f"navigation.start_s: must be < duration_s = {duration_s!r}, got {nav.start_s!r}")
    fs = imu.filter_rate_hz
    if nav is not None and nav.tuned and (nav.designs is None or not set(filters) <= set(nav.designs)):
        nav = dataclasses.replace(nav, designs=tuned_designs(imu, filters, nav.tuned_band_hz))
    fp = imu.plant_rate_hz
    r_dec = imu.channels[0].readout.decimation
    n_out = int(math.floor(duration_s * fs + 1e-9))
    if n_out < 8:
        raise ValueError(f"run.duration_s: must cover at least 8 filter samples, got {duration_s!r}")
    chunk = max(1, int(round(chunk_s * fs)))
    threads = default_threads() if threads is None else int(threads)
    if vehicle is None:
        vehicle = stationary_vehicle(duration_s + 1.0)
    elif hasattr(vehicle, "duration_s") and vehicle.duration_s < duration_s + 0.1:
        raise ValueError(f"run.duration_s: the trajectory lasts {vehicle.duration_s:g} s, shorter than the run "
                         f"({duration_s:g} s) plus 0.1 s")
    stream = vehicle.stream() if hasattr(vehicle, "stream") else vehicle
    # a filter to feed, or a block whose motion comes out of the suspensions: the plant runs
    plant_inputs = any(name != "ideal" for name in filters) or imu.block is not None
    # without navigation the truth forms only the plant's gyro inputs
    motion_on_block = imu.block is not None and motion_enters == "block"
    truth = MissionTruth(stream, motion, translation, fp, fs, navigation=nav is not None or not plant_inputs,
                         keep_chassis=motion_on_block)
    # the unit: its block (rigid, or on isolators) and the three channels on it
    unit = SensorUnit(imu, seed, plugins=plugins, deflection=bool(plugins3))
    chains = unit.chains
    # three-axis plug-ins: the pickoffs sampled at the filter rate, one noise stream per coil [seed, 6, axis]
    flt3 = {}
    pickoffs = None
    if plugins3:
        import dataclasses

        # an integrating converter read once per filter sample averages r_dec of its plant-rate samples: the white
        # noise given per plant-rate sample falls by sqrt(r_dec)
        coils = tuple(dataclasses.replace(c, rate_hz=fs, noise_v=c.noise_v / math.sqrt(r_dec))
                      for c in imu.pickoff.coils)
        pickoffs = PickoffTriad(PickoffTriadParams(coils, imu.pickoff.coupling),
                                [np.random.default_rng([seed, 6, i]) for i in range(3)])
        ctx3 = [ch.cfg.filter_context(AXES[i]) for i, ch in enumerate(chains)]
        for name in plugins3:
            flt3[name] = filter_registry.build(name, filter_registry.ThreeAxisContext(
                axes=tuple(ctx3), pickoff_scale_v_per_rad_s=tuple(c.scale_v_per_rad_s for c in coils),
                settings=dict(imu.filter_settings.get(name) or {})))
    accel = Accelerometer(imu.accelerometer, np.random.default_rng([seed, 3]))
    # sensor errors beyond the dither physics, generated at the filter rate from the true increments and added to
    # every filter's increments at that filter's alignment (they pass the filters at unity gain: exact for the
    # low-frequency terms; the white noise is not shaped by the filters' passbands in this model)
    sens = imu.sensors
    gyro_err = (GyroErrors(sens.gyro, np.random.default_rng([seed, 4]), 1.0 / fs)
                if sens is not None and not sens.gyro.is_ideal else None)
    accel_err = (AccelErrors(sens.accelerometer, np.random.default_rng([seed, 5]), 1.0 / fs)
                 if sens is not None and not sens.accelerometer.is_ideal else None)

    # alignment shifts (filter samples)
    ro_delay = chains[0].readout.delay_s * fs
    elim_gd = float(np.mean([float(ch.filters["eliminator"].design.group_delay_s(0.0)) for ch in chains])) * fs
    delays = {"ideal": 0, "raw": int(round(ro_delay)), "correcting": int(round(ro_delay)) + 1,
              "correcting_paper": int(round(ro_delay)) + 1, "eliminator": int(round(ro_delay + elim_gd))}
    residual_delay = {"eliminator": ro_delay + elim_gd - delays["eliminator"]}
    for name in plugins:
        dly = ro_delay + float(np.mean([float(ch.plugins[name].delay_samples) for ch in chains]))
        delays[name] = int(round(dly))
        residual_delay[name] = dly - delays[name]
    for name, flt in flt3.items():
        dly = ro_delay + float(flt.delay_samples)
        delays[name] = int(round(dly))
        residual_delay[name] = dly - delays[name]
    max_delay = max(delays[n] for n in filters)

    # buffers indexed by filter sample
    cap = 2 * chunk + max_delay + 16  # ring rows: a chunk and what the previous one left behind, without regrowing
    outs_buf = {name: _Ring((3,), cap) for name in filters if name != "ideal"}
    phi_buf = _Ring((3,), cap)  # true gyro angles (the ideal output)
    tr_buf = {k: _Ring(w, cap) for k, w in (("q", (4,)), ("lat", ()), ("lon", ()), ("h", ()), ("v", (3,)),
                                            ("dv", (3,)), ("dth", (3,)), ("gerr", (3,)), ("gcum", (3,)),
                                            ("acum", (3,)), ("aerr", (3,)))}
    navs = {}
    if nav is not None:
        k_start = int(round(nav.start_s * fs))
        every = max(1, int(round(fs / nav.n_sub / nav.series_rate_hz(duration_s))))
        aid_mission = (AidedMission(nav.aiding, nav.alignment, fs, nav.n_sub, duration_s, seed, nav.compensation,
                                     sensors=sens, vehicle=vehicle)
                       if nav.aiding is not None else None)
        for name in filters:
            d = delays[name]
            navs[name] = _FilterNav(name, d, d if nav.accel_delay == "none" else 0)
            navs[name].aid_mission = aid_mission
            navs[name].n_out = n_out
            if nav.alignment.active:  # the window (k_start - n, k_start] feeds the alignment
                navs[name].aligner = AlignmentAccumulator(nav.alignment, nav.n_sub, 1.0 / fs)
                navs[name].align_next = k_start - int(round(nav.alignment.duration_s * fs)) + 1
        truth_every = every * nav.n_sub
        n_spec = int(round(nav.spectrum_s * fs))
        spec_next = k_start
        n_align = min(k_start, int(round(nav.align_s * fs)))
        allan_rate = min(ALLAN_RATE_HZ, ALLAN_MAX_SAMPLES / max(duration_s - nav.start_s, 1e-9))
        allan_stride = max(1, int(math.ceil(fs / allan_rate - 1e-9)))
        allan_next = k_start
        allan_rec = {name: [] for name in filters}
        allan_rec["accelerometers"] = []
        allan_rec["velocity_ned_m_s"] = []
    spectra = {name: [] for name in filters}
    truth_series = {"t_s": [], "lat_rad": [], "lon_rad": [], "h_m": []}
    diverged = {}
    caught = []
    # One thread: the three suspensions side by side. Several, with navigation: side by side on one worker
    # while this thread prepares the next chunk's truth and navigates (they take about as long as the
    # kernels); without navigation, one thread per axis (the truth alone is too light to fill this one).
    run_chains = bool(outs_buf) or imu.block is not None
    three = unit.mechanics(bool(outs_buf) and (threads <= 1 or nav is not None))
    pool = axis_pool(threads) if run_chains and three is None else None
    worker = None
    if three is not None and threads > 1:
        from concurrent.futures import ThreadPoolExecutor

        worker = ThreadPoolExecutor(max_workers=1, thread_name_prefix="sins-axes")
    last_out = {}
    g_cum = np.zeros(3)
    a_cum = np.zeros(3)
    chassis_linear = imu.block is not None and translation is not None and vibration_enters == "chassis"
    block_win = ((k_start, min(k_start + n_spec, n_out + 1)) if nav is not None
                 else (1, min(1 + int(round(2.0 * fs)), n_out + 1)))

    def stage(k_a, k_b):
        """The truth of filter nodes up to ``k_b`` and the chains started on its plant steps."""
        tc, ang, rate = truth.advance(k_b, plant=plant_inputs)
        # the isolators' linear input, sampled here (the vibration streams are not for sampling from two threads)
        lin = truth.chassis_linear(k_a, k_b) if chassis_linear else None
        base = truth.chassis_angle_rate() if motion_on_block else None  # the chassis without the block's profile
        job = submit_axes(chains, k_a * r_dec, ang, rate, pool, three, worker, lin, base) if run_chains else None
        return k_a, k_b, tc, job

    try:
        pending = stage(0, min(chunk, n_out))
        while pending is not None:
            k_prev, k1, tc, job = pending
            # pipeline: the next chunk's truth is prepared (and its kernels queued behind this chunk's on each
            # axis) while this chunk's kernels run; this chunk is navigated while the next one's kernels run
            pending = stage(k1, min(k1 + chunk, n_out)) if k1 < n_out else None
            outs = collect_axes(chains, job, caught) if run_chains else []
            if nav is not None:  # the truth out of the mechanics: what the block's own motion adds to it
                unit.amend_truth(tc, outs)
            unit.keep(outs, k_prev, k1, block_win)  # the block's rotation over the spectrum window
            if flt3:
                _run_three_axis(flt3, pickoffs, outs)
            if nav is not None:  # the truth rows for nodes tc.k0 .. k1 and the sensors feed only the navigation
                phi_buf.push(tc.phi_rad)
                for key, arr in (("q", tc.q_nb), ("lat", tc.lat_rad), ("lon", tc.lon_rad), ("h", tc.h_m),
                                 ("v", tc.v_ned_m_s), ("dth", tc.dtheta_rad)):
                    tr_buf[key].push(arr)
                dv_meas = accel.process(tc.dv_m_s if accel_err is None else accel_err.apply(tc.dv_m_s))
                tr_buf["dv"].push(dv_meas)
                a_err = dv_meas - tc.dv_m_s  # the accelerometers' error (the interval means of the velocity error)
                tr_buf["aerr"].push(a_err)
                a_cum = a_cum + np.cumsum(a_err, axis=0)  # accumulated accelerometer error (Allan)
                tr_buf["acum"].push(a_cum)
                a_cum = a_cum[-1]
                g_e = (np.zeros_like(tc.dtheta_rad) if gyro_err is None
                       else gyro_err.apply(tc.dtheta_rad) - tc.dtheta_rad)
                tr_buf["gerr"].push(g_e)
                if gyro_err is None:  # no sensor errors: the error angle stays zero (what the sum of zeros gives)
                    tr_buf["gcum"].push(g_e)
                else:
                    g_cum = g_cum + np.cumsum(g_e, axis=0)  # accumulated sensor error angle (free attitude error)
                    tr_buf["gcum"].push(g_cum)
                    g_cum = g_cum[-1]
            for name in outs_buf:
                cols = [o[name] for o in outs]
                outs_buf[name].push_columns(cols)
                y = outs_buf[name].a[outs_buf[name].a.shape[0] - cols[0].shape[0]:]  # this chunk's rows (a view)
                last_out[name] = y[-1].copy()
                if name not in diverged and not np.all(np.isfinite(y)):
                    bad = np.argwhere(~np.isfinite(y))[0]
                    diverged[name] = {"axis": AXES[int(bad[1])], "time_s": (k_prev + int(bad[0])) / fs,
                                      "reason": getattr(flt3.get(name), "failure", None) or "filter output not finite"}
            if nav is not None:
                if aid_mission is not None:  # the fixes whose truth rows have arrived (before any filter needs them)
                    aid_mission.make_fixes(tr_buf)
                _navigate(navs, nav, tr_buf, outs_buf, phi_buf, k_start, fs, every, diverged, n_align)
                spec_next = _keep_spectra(spectra, spec_next, outs_buf, phi_buf, delays, k1, min(k_start + n_spec, n_out),
                                          max_delay, filters)
                _keep_truth_series(truth_series, tr_buf, k_prev, k1, k_start, truth_every, fs)
                allan_next = _keep_allan(allan_rec, allan_next, allan_stride, outs_buf, phi_buf, tr_buf, delays, k1,
                                         n_out, max_delay, filters)
                # drop what no filter needs any more
                # (from the last update on: the next update's interval mean reads every sample of its interval)
                keep = [min(nf.next_j, nf.epoch_j) if nf.next_j is not None
                        else (nf.align_next - 1 if nf.align_next is not None else k_start - n_align)
                        for nf in navs.values() if nf.diverged is None]
                if spec_next < min(k_start + n_spec, n_out):
                    keep.append(spec_next)
                keep.append(allan_next)
                need = min(keep or [k1])
                low = min(need, k1 - max_delay - 2) - 2
                for r in tr_buf.values():
                    r.drop_before(low)
                phi_buf.drop_before(low)
                for name, r in outs_buf.items():
                    r.drop_before(low + delays[name] - 1)
            else:
                for r in outs_buf.values():
                    r.drop_before(k1 - 2)
            if progress is not None:
                progress(k1 / n_out)
    finally:
        for ex in (pool or []) + ([worker] if worker is not None else []):
            ex.shutdown(wait=True, cancel_futures=True)

    drives = [{"axis": AXES[i], "f0_hz": ch.cfg.suspension.f0_hz, "frequency_hz": ch.drive.frequency_hz,
               "v_m_initial": ch.v_m0, "v_m_final": ch.v_m, "amplitude_measured_rad": ch.amp_meas,
               "amplitude_target_rad": ch.cfg.drive.amplitude_rad} for i, ch in enumerate(chains)]
    spec = {}
    if nav is not None:
        lens = [sum(x.shape[0] for x in spectra[n]) for n in filters]
        n_sp = min(lens) if lens else 0
        spec = {n: (np.concatenate(spectra[n])[:n_sp] if spectra[n] else np.zeros((0, 3))) for n in filters}
        spec["t"] = (k_start + np.arange(n_sp)) / fs
    series = {n: nf.series.arrays() for n, nf in navs.items() if nf.series is not None}
    records = _error_records(allan_rec, fs / allan_stride, k_start / fs, diverged) if nav is not None else {}
    allan = _allan_analyses(records, diverged) if nav is not None else {}
    ts = {k: (np.concatenate(a) if a else np.zeros(0)) for k, a in truth_series.items()}
    aided = {}
    if nav is not None and aid_mission is not None:
        from sins_sim.navigation.gnss import concat_fixes

        for n, nf in navs.items():
            if nf.aided is not None and n not in diverged:
                aided[n] = aid_mission.finish(nf.aided, records, n,
                                              np.zeros(3) if gyro_err is None else gyro_err.bias,
                                              np.zeros(3) if accel_err is None else accel_err.bias)
                nf.aided = None  # its covariance matrices go with it
        if aid_mission.parts:
            aided["fixes"] = concat_fixes(aid_mission.parts)
    return SinsResult(stats={n: nf.stats for n, nf in navs.items()}, series=series, truth_series=ts, spectra=spec,
                      delays=dict(delays, residual_eliminator=residual_delay), diverged=diverged, drives=drives,
                      filter_rate_hz=fs, duration_s=duration_s, nav_start_s=(nav.start_s if nav else 0.0),
                      warnings=list(dict.fromkeys(caught)), filters=filters, nav=nav, outputs_last=last_out,
                      allan=allan, records=records,
                      filter_reports={n: f.report() for n, f in flt3.items() if hasattr(f, "report")},
                      block=unit.record(block_win[0], fs),
                      online={AXES[i]: {"history": ch.online.history, "events": list(ch.online.estimator.events)}
                              for i, ch in enumerate(chains) if ch.online is not None},
                      alignments={n: {"result": nf.alignment["result"],
                                      "error_rad": attitude_error(nf.alignment["result"].q_nb, nf.alignment["q_true"])}
                                  for n, nf in navs.items() if nf.alignment is not None},
                      aided=aided)


def _run_three_axis(flt3, pickoffs, outs) -> None:
    """The three-axis plug-ins on one chunk: the pickoff voltages from the three deflections, then each filter on
    the three readouts; its rows land in each axis's outputs."""
    x = np.stack([o["raw"] for o in outs])
    volts = pickoffs.process(np.stack([o["deflection"] for o in outs]))
    for name, flt in flt3.items():
        y = np.asarray(flt.process(x, volts), dtype=np.float64)
        for a, o in enumerate(outs):
            o[name] = y[a]


_NO_REF = np.zeros(3)
_NO_AID = np.zeros(0)


def _navigate(navs, nav: NavSettings, tr_buf, outs_buf, phi_buf, k_start, fs, every, diverged, n_align):
    """Advance every filter's navigation as far as its aligned data reach; record divergences.

    (Navigating the filters on a thread pool beside the next chunk's kernels was measured: no
    faster on 2 cores, so they run in the calling thread, one after the other.)
    """
    for name, nf in navs.items():
        if nf.diverged is None:
            record = _navigate_one(name, nf, nav, tr_buf, outs_buf, phi_buf, k_start, fs, every, n_align)
            if record is not None:
                nf.diverged = diverged.setdefault(name, record)


def _navigate_one(name, nf, nav: NavSettings, tr_buf, outs_buf, phi_buf, k_start, fs, every, n_align):
    """One filter's navigation over the data available; returns a divergence record or None."""
    out_end = (phi_buf.end if name == "ideal" else outs_buf[name].end)  # outputs available: [.., out_end)
    j_end = min(out_end - nf.d, tr_buf["dv"].end - nf.dv_shift, tr_buf["q"].end)  # truth indices < j_end
    if nf.nav is None:
        j0 = k_start
        if nf.aligner is not None:  # the alignment window (j0 - n, j0] fills first, from the unit's own increments
            ja, jb = nf.align_next, min(j_end, j0 + 1)
            if jb > ja:
                dth, dv = _unit_increments(name, nf, tr_buf, outs_buf, ja, jb, False)
                nf.aligner.add(dth, np.ascontiguousarray(dv))
                nf.align_next = jb
            if nf.align_next <= j0:
                return None
        if j_end <= j0 + 1:
            return None
        lat0, lon0, h0 = (float(tr_buf[k].get(j0, j0 + 1)[0]) for k in ("lat", "lon", "h"))
        q_true = tr_buf["q"].get(j0, j0 + 1)[0]
        if nf.aligner is not None:
            # the attitude found by the unit's own alignment; the surveyed position; at rest: zero velocity
            result = nf.aligner.finish(lat0, lon0, h0)
            nf.alignment = {"result": result, "q_true": q_true.copy()}
            nf.aligner = None
            q0, v0 = result.q_nb, np.zeros(3)
        else:
            q0, v0 = q_true, tr_buf["v"].get(j0, j0 + 1)[0]
        coning, sculling = nav.compensation(name)
        nf.nav = StrapdownNavigator(lat0, lon0, h0, v0, q0,
                                    1.0 / fs, coning=coning, sculling=sculling, n_sub=nav.n_sub,
                                    vertical=nav.vertical, height_aid_tau_s=nav.height_aid_tau_s)
        if nf.aid_mission is not None:  # the aided run starts where the free navigation does, from the same state
            nf.aided = nf.aid_mission.start_run(name, j0, nf.n_out - nf.d - 1 - j0, lat0, lon0, h0, v0, q0,
                                                None if nf.alignment is None else nf.alignment["result"])
        nf.j0 = j0
        nf.next_j = j0 + 1
        nf.epoch_j = j0
        nf.free[3:6] = tr_buf["gcum"].get(j0, j0 + 1)[0]
        if name != "ideal" and nf.alignment is not None:
            # no truth reference: the increments are the output's own differences from j0 on; the free attitude
            # error accumulates the gyro-angle error from there (the alignment's own error is in psi, not in it)
            nf.free[3:6] += outs_buf[name].get(j0 + nf.d, j0 + nf.d + 1)[0] - phi_buf.get(j0, j0 + 1)[0]
        elif name != "ideal":
            # alignment: the filter's gyro-angle offset from the truth, averaged over the alignment window
            # (as a fine alignment averages its sensors), is the reference of the first increment; a single
            # sample would carry its own residual (quantisation, dither) into the run as a tilt
            w0 = max(outs_buf[name].base - nf.d, phi_buf.base, j0 - n_align)
            off = (outs_buf[name].get(w0 + nf.d, j0 + nf.d + 1) - phi_buf.get(w0, j0 + 1)).mean(axis=0)
            nf.ref = phi_buf.get(j0, j0 + 1)[0] + off
            nf.free[3:6] = off + tr_buf["gcum"].get(j0, j0 + 1)[0]
        nf.series = ErrorSeries(every, nav.n_sub / fs, j0 / fs, nav.n_sub)
        # the error at the start, aligned: zero but the solution's position; the gyro-angle error the first
        # increment starts from, the accelerometers' accumulated error there
        nf.prev_row = np.zeros(N_COLS)
        nf.prev_row[10] = tr_buf["lat"].get(j0, j0 + 1)[0]
        nf.prev_row[11] = tr_buf["lon"].get(j0, j0 + 1)[0]
        nf.fast_state[0:3] = nf.free[3:6]
        nf.fast_state[3:6] = tr_buf["gcum"].get(j0, j0 + 1)[0]
    ja, jb = nf.next_j, j_end
    if jb <= ja:
        return None
    # the first increment starts from the aligned reference (a truth start; an alignment has none)
    dth, dv = _unit_increments(name, nf, tr_buf, outs_buf, ja, jb, ja == nf.j0 + 1 and nf.ref is not None)
    h_aid = tr_buf["h"].get(ja, jb) if nav.vertical == "height_aid" else _NO_AID
    bad = ktruth.first_not_finite(dth, dv, h_aid)
    if bad in (-1, -3) and dv.shape[0] != dth.shape[0]:  # pragma: no cover - the ring windows share one rule
        bad = -4
    if bad >= 0 or bad == -2:
        ax = AXES[bad % 3] if bad >= 0 else "-"
        return {"axis": ax, "time_s": (ja + (bad // 3 if bad >= 0 else 0)) / fs,
                "reason": "angle increments not finite"}
    n_before = nf.nav.n_updates
    if bad == -1 and nf.aided is not None:  # the same increments through the aided navigation
        nf.aid_mission.feed(nf.aided, dth, dv, tr_buf)
    if bad == -1:  # checked here: the kernel directly (StrapdownNavigator.process checks and copies)
        out = nf.nav._run(dth, np.ascontiguousarray(dv), h_aid if nav.vertical == "height_aid" else _NO_AID)
    else:  # a height aid that is not finite, or windows of unequal length: the public path raises its error
        nf.nav.process(dth, dv, h_aid if nav.vertical == "height_aid" else None)
        raise AssertionError("StrapdownNavigator.process accepted what the engine's check refused")
    nf.next_j = jb
    m = out.shape[0]
    if m == 0:
        return None
    # truth index of each update: j0 + n_sub (n_before + 1 + i), i < m
    lo = nf.j0 + nav.n_sub * (n_before + 1)
    hi = lo + nav.n_sub * (m - 1) + 1
    step = nav.n_sub
    # gyro-angle error (output minus truth) at the updates, for the free attitude error
    e_body = tr_buf["gcum"].get(lo, hi, step)  # the sensor errors' angle, plus the filter's own error
    if name != "ideal":
        e_body = e_body + outs_buf[name].get(lo + nf.d, hi + nf.d, step) - phi_buf.get(lo, hi, step)
    rows = np.empty((m, N_COLS))
    q_t = tr_buf["q"].get(lo, hi, step)
    bad = ktruth.nav_errors(out[:, OUT_LAT], out[:, OUT_LON], out[:, OUT_H], out[:, OUT_V:OUT_V + 3],
                            out[:, OUT_Q:OUT_Q + 4], tr_buf["lat"].get(lo, hi, step),
                            tr_buf["lon"].get(lo, hi, step), tr_buf["h"].get(lo, hi, step),
                            _surface_scales(tr_buf, lo, hi, step), tr_buf["v"].get(lo, hi, step),
                            q_t, e_body, nf.free, DIVERGED_ATTITUDE_RAD,
                            DIVERGED_VELOCITY_M_S, DIVERGED_POSITION_M, rows)
    rows[:, 10] = out[:, OUT_LAT]
    rows[:, 11] = out[:, OUT_LON]
    means = _interval_means(name, nf, tr_buf, outs_buf, phi_buf, lo, hi, step, q_t, rows) if step > 1 else None
    record = None
    if bad >= 0:
        record = {"axis": "-", "time_s": float((lo + step * bad) / fs), "reason": divergence_reason(rows[bad])}
        rows = rows[:bad]
        means = None if means is None else means[:bad]
    nf.stats.add(rows, (lo + step * np.arange(rows.shape[0])) / fs)
    nf.series.add(rows, means)
    nf.epoch_j = hi - 1
    return record


def _unit_increments(name, nf, tr_buf, outs_buf, ja, jb, use_ref):
    """The unit's increments of truth indices ``ja .. jb - 1``: the filter's output differenced plus the
    sensor errors (``ideal``: the true increments plus the sensor errors), and the accelerometers'."""
    gerr = tr_buf["gerr"].get(ja, jb)
    if name == "ideal":
        dth = tr_buf["dth"].get(ja, jb) + gerr
    else:
        y = outs_buf[name].get(ja + nf.d - 1, jb + nf.d)
        dth = np.empty(gerr.shape)
        ktruth.filter_increments(y, nf.ref if use_ref else _NO_REF, use_ref, gerr, dth)
    return dth, tr_buf["dv"].get(ja + nf.dv_shift, jb + nf.dv_shift)


def _surface_scales(tr_buf, lo, hi, step):
    """:func:`sins_sim._kernels.truth.surface_scales` of the truth rows at the updates ``lo, lo + step, .. < hi``
    only: the error bookkeeping reads them nowhere else (per row the same values as for every truth row)."""
    lat = np.ascontiguousarray(tr_buf["lat"].get(lo, hi, step))
    out = np.empty((lat.shape[0], 3))
    ktruth.surface_scales(lat, np.ascontiguousarray(tr_buf["h"].get(lo, hi, step)), out)
    return out


_NO_ROWS = np.zeros((0, 3))


def _interval_means(name, nf, tr_buf, outs_buf, phi_buf, lo, hi, step, q_t, rows):
    """The error rows averaged over each update's filter samples (:mod:`sins_sim._kernels.series`).

    Every column but the solution's latitude and longitude: the mean of its straight line between the updates
    (the rows at ``lo, lo + step, .. < hi`` and the one before ``lo``), plus for the attitude (and the free
    attitude) and the velocity the mean of their between-epoch part, measured from the filter-rate gyro-angle
    and velocity-increment errors. Position and height take the line alone: their between-epoch part is the
    velocity's integrated over at most ``step`` samples (a 387 Hz velocity line of 1e-4 m/s moves the position
    by 4e-8 m)."""
    a = lo - step + 1  # the first filter sample of the first interval
    y, phi = _NO_ROWS, _NO_ROWS
    if name != "ideal":
        y, phi = outs_buf[name].get(a + nf.d, hi + nf.d), phi_buf.get(a, hi)
    dv_fed = dv_here = _NO_ROWS
    if nf.dv_shift:
        dv_fed, dv_here = tr_buf["dv"].get(a + nf.dv_shift, hi + nf.dv_shift), tr_buf["dv"].get(a, hi)
    fast = np.empty((rows.shape[0], 6))
    means = np.empty_like(rows)
    kseries.interval_means(step, q_t, y, phi, tr_buf["gerr"].get(a, hi), tr_buf["aerr"].get(a, hi), dv_fed, dv_here,
                           rows, nf.prev_row, nf.fast_state, fast, means)
    return means


def _keep_spectra(spectra, spec_next, outs_buf, phi_buf, delays, k1, k_end, max_delay, filters):
    """Gyro-angle error (output minus aligned truth) at full rate for truth indices ``[spec_next, k_end)``.

    Returns the next truth index still to keep (``k_end`` when the window is complete)."""
    hi = min(k_end, k1 - max_delay - 1)
    if hi <= spec_next:
        return spec_next
    truth = phi_buf.get(spec_next, hi)
    for name in filters:
        if name == "ideal":
            spectra[name].append(np.zeros_like(truth))
        else:
            d = delays[name]
            spectra[name].append(outs_buf[name].get(spec_next + d, hi + d) - truth)
    return hi


def _keep_allan(rec, nxt, stride, outs_buf, phi_buf, tr_buf, delays, k1, n_out, max_delay, filters):
    """Sample the gyro-angle and velocity errors every ``stride`` filter samples from truth index ``nxt`` on.

    Returns the next truth index to sample."""
    hi = min(n_out, k1 - max_delay - 1, tr_buf["acum"].end)
    if hi <= nxt:
        return nxt
    idx = np.arange(nxt, hi, stride)
    lo, top = int(idx[0]), int(idx[-1]) + 1
    sel = idx - lo
    gcum = tr_buf["gcum"].get(lo, top)[sel]
    truth = phi_buf.get(lo, top)[sel]
    for name in filters:
        if name == "ideal":
            rec[name].append(gcum.copy())
        else:
            d = delays[name]
            rec[name].append(outs_buf[name].get(lo + d, top + d)[sel] - truth + gcum)
    rec["accelerometers"].append(tr_buf["acum"].get(lo, top)[sel].copy())
    rec["velocity_ned_m_s"].append(tr_buf["v"].get(lo, top)[sel].copy())  # smoothed to a speed at the end
    return int(idx[-1]) + stride


def _error_records(rec, rate_hz, t0_s, diverged) -> dict:
    """The sampled error records as arrays (see :attr:`SinsResult.records`); filters that diverged are left out."""
    speed = rec.get("velocity_ned_m_s") or []
    n = sum(x.shape[0] for x in speed)
    if n == 0:
        return {}
    out = {"rate_hz": rate_hz, "t_s": t0_s + np.arange(n) / rate_hz,
           "speed_m_s": _vehicle_speed(np.concatenate(speed), rate_hz)}
    for name, parts in rec.items():
        if name == "velocity_ned_m_s" or name in diverged or not parts:
            continue
        x = np.concatenate(parts)
        if x.shape[0] == n and np.all(np.isfinite(x)):
            out[name] = x
    return out


def _vehicle_speed(v_ned, rate_hz, window_s: float = REST_WINDOW_S):
    """The norm of the velocity averaged over a centred ``window_s`` window (m/s): the vehicle's speed, without
    the block's vibration velocity (tens of Hz and up: cm/s at 0.002 g^2/Hz, which averages out over 1 s)."""
    m = max(1, min(int(round(window_s * rate_hz)), v_ned.shape[0]))
    c = np.concatenate([np.zeros((1, 3)), np.cumsum(v_ned, axis=0)])
    lo = np.clip(np.arange(v_ned.shape[0]) - m // 2, 0, v_ned.shape[0] - m)
    return np.linalg.norm((c[lo + m] - c[lo]) / m, axis=1)


def rest_span(speed_m_s, rest_speed_m_s: float = REST_SPEED_M_S):
    """``(start, stop)`` sample indices of the longest span where the vehicle is at rest, or None."""
    at_rest = np.concatenate([[False], np.asarray(speed_m_s) < rest_speed_m_s, [False]])
    edges = np.flatnonzero(np.diff(at_rest.astype(np.int8)))
    if edges.size == 0:
        return None
    starts, stops = edges[0::2], edges[1::2]
    k = int(np.argmax(stops - starts))
    return int(starts[k]), int(stops[k])


def _allan_analyses(records, diverged) -> dict:
    """Allan analyses of the sampled error records (see :attr:`SinsResult.allan`).

    Noise terms are read only where they can mean something: on the longest span where the vehicle
    is at rest (a manoeuvre's errors are deterministic, not noise), with the deterministic part that
    the rest span can carry removed (a least-squares line through the accumulated error: a constant
    bias, which the Allan variance does not see either, and the alignment offset), and only where the
    power-law model describes the curve (:func:`sins_sim.navigation.allan.screen_noise`). Otherwise
    every term of that record is "not determinable", with the reason.
    """
    from sins_sim.navigation.allan import allan_axes, not_determinable, screen_noise

    if not records:
        return {}
    rate_hz = records["rate_hz"]
    names = [k for k in records if k not in ("rate_hz", "t_s", "speed_m_s")]
    span = rest_span(records["speed_m_s"])
    n_rest = 0 if span is None else span[1] - span[0]
    out = {"rate_hz": rate_hz, "record_s": n_rest / rate_hz if n_rest else 0.0,
           "rest_span_s": ([float(records["t_s"][span[0]]), float(records["t_s"][span[1] - 1])] if span else None)}
    for name in names:
        sensor = "accel" if name == "accelerometers" else "gyro"
        if n_rest < ALLAN_MIN_SAMPLES:
            why = (f"the vehicle is at rest for {n_rest / rate_hz:.3g} s at most (need {ALLAN_MIN_SAMPLES} samples, "
                   f"{ALLAN_MIN_SAMPLES / rate_hz:.3g} s): noise terms are read only at rest, where the error is not "
                   "the deterministic response to a manoeuvre")
            out[name] = {ax: not_determinable(sensor, why, rate_hz) for ax in AXES}
            continue
        x = records[name][span[0]:span[1]]
        t = np.arange(x.shape[0]) / rate_hz
        coef = np.polyfit(t, x, 1)  # the deterministic part: offset and constant bias (a line in angle/velocity)
        x = x - (coef[0][None, :] * t[:, None] + coef[1][None, :])
        data = "velocity" if sensor == "accel" else "angle"
        rms = np.sqrt(np.mean(x * x, axis=0))
        quiet = rms < ALLAN_NOISE_FLOOR
        x[:, quiet] = 0.0  # (not analysed; keeps allantools away from a rounding-only record)
        res = {ax: screen_noise(a) for ax, a in allan_axes(x, rate_hz, sensor=sensor, data=data).items()}
        for i, ax in enumerate(AXES):
            if quiet[i]:
                res[ax] = not_determinable(sensor, f"the record carries no noise: {rms[i]:.2g} RMS once a line is "
                                                   f"removed, below the rounding floor {ALLAN_NOISE_FLOOR:g} (SI)",
                                           rate_hz)
        out[name] = res
    return out


def _keep_truth_series(ts, tr_buf, k_prev, k1, k_start, every, fs):
    lo = max(k_prev, k_start)
    first = lo + (-(lo - k_start)) % every
    idx = np.arange(first, k1, every)
    idx = idx[idx < tr_buf["lat"].end]
    if idx.size == 0:
        return
    ts["t_s"].append(idx / fs)
    for key, name in (("lat", "lat_rad"), ("lon", "lon_rad"), ("h", "h_m")):
        r = tr_buf[key]
        ts[name].append(r.a[idx - r.base])
