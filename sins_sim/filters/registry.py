"""Dither filters selectable by name beyond the built-in ones (plug-ins).

The engine's fused kernel (``sins_sim._kernels.chain``) runs the built-in filters: ``raw``,
``eliminator``, ``correcting`` (eq. 5, unity DC) and ``correcting_paper`` (eq. 5 as printed).
Any further filter is a *plug-in*: a streaming filter that reads the same decimated readout
``x`` (rad, the filter rate) and the drive voltage ``volts`` through the same anti-alias chain
(V) that eq. 5 reads, one chunk at a time, on the axis's own thread. A plug-in is registered
under a name and then selectable wherever a filter name is: the ``filters`` of
:func:`~sins_sim.simulation.sins.simulate_sins`, scenarios, sweeps and the error budget.

A plug-in is built per axis from a :class:`FilterContext` (what the filter is allowed to know:
the parameters it believes, not the unit's true ones unless the run says so) and must provide

``process(x, volts) -> y``
    The output for one chunk (same length as ``x``), streaming: the concatenation of chunk
    outputs equals the output on the concatenated input.
``delay_samples``
    How late the output is relative to ``x`` (filter samples, float), at DC: the engine
    shifts the navigation by ``round(readout delay + delay_samples)`` filter samples and
    reports the fractional remainder (accelerometers are delayed to match).
``reset()``
    Back to the state before the first chunk.

and may provide ``check_output(x, y)`` (raises its warnings, once per run). Its cost per sample
is measured by the benchmarks, not declared.

A *three-axis* plug-in (``register(..., three_axis=True)``, or a name in :data:`THREE_AXIS`) is built once for
the unit from a :class:`ThreeAxisContext` and reads the three axes' readouts and
the three dither pickoffs together: ``process(x, volts) -> y`` with ``x`` the readouts (rad) and ``volts`` the
pickoff voltages (V) at the filter rate, all (3, m); ``delay_samples`` and ``reset()`` as above; optionally
``failure`` (why its output stopped being finite) and ``report()`` (a dict for ``metrics.json``). The SINS engine
runs it on the calling thread once the three axes' chunk is in; single-channel runs cannot.

Registering: ``register(name, builder, description)`` with ``builder(ctx) -> filter``, or an
entry ``name: "module:function"`` in :data:`_LAZY` for filters shipped with sins-sim (imported
on first use, so ``import sins_sim`` stays light).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass

__all__ = ["BUILTIN_FILTERS", "FilterContext", "register", "plugin_names", "shipped_plugin_names", "build", "describe",
           "is_known", "is_three_axis", "THREE_AXIS", "ThreeAxisContext", "takes_parameters", "parameter_filters"]

#: Filters computed by the engine's fused kernel (plus ``ideal``, the true increments).
BUILTIN_FILTERS = ("ideal", "raw", "eliminator", "correcting", "correcting_paper")
#: The filters a scenario navigates by default: the dither filters and the ideal floor (``raw``, the readout
#: with the dither still in it, on request).
DEFAULT_FILTERS = ("ideal", "eliminator", "correcting", "correcting_paper")


@dataclass(frozen=True)
class FilterContext:
    """What a plug-in filter of one axis is built from (SI units, rad).

    Attributes
    ----------
    f0_hz : float
        The resonance the filter believes (Hz): the unit's, the datasheet's or a tracked one,
        depending on the run's filter parameters.
    k1, k2, k3, k4, k5 : float
        Suspension parameters the filter believes (eq. 9, 10, 14; k2 in rad, k4 in 1/rad,
        k5 in rad/V).
    fs_hz : float
        Filter rate (Hz).
    dither_hz : float
        The drive frequency of the axis (Hz).
    hysteresis : str
        Hysteresis rule of eq. 10 inside the filter (``paper`` or ``masing``).
    quantum_rad : float
        Readout quantum (rad), for filters that bound their noise gain.
    axis : str
        ``x``, ``y`` or ``z``.
    """

    f0_hz: float
    k1: float
    k2: float
    k3: float
    k4: float
    k5: float
    fs_hz: float
    dither_hz: float
    hysteresis: str = "paper"
    quantum_rad: float = 0.0
    axis: str = "x"


@dataclass(frozen=True)
class ThreeAxisContext:
    """What a three-axis plug-in is built from: the per-axis contexts, the pickoffs' nominal scales, its settings.

    Attributes
    ----------
    axes : tuple of three FilterContext
        Axes x, y, z (:class:`FilterContext`).
    pickoff_scale_v_per_rad_s : tuple of three float
        Nominal pickoff sensitivities (V per rad/s): what the filter believes, not the coils' actual ones.
    settings : dict
        The filter's settings from the IMU file (its own section), validated by the filter.
    """

    axes: tuple
    pickoff_scale_v_per_rad_s: tuple = (1.0, 1.0, 1.0)
    settings: dict | None = None

    @property
    def fs_hz(self) -> float:
        return float(self.axes[0].fs_hz)


_REGISTRY: dict = {}
#: Plug-ins shipped with sins-sim: name -> ("module:builder", one-line description).
_LAZY: dict = {
    "correcting_aligned": ("sins_sim.filters.wideband:build_aligned",
                           "eq. 5 (unity DC) with Nonl and Diss solved on the output's own instant; delay 1 sample"),
    "correcting_wideband": ("sins_sim.filters.wideband:build_wideband",
                            "equalised second difference, flat to 2.6 kHz, band edge 3.2 kHz; delay 16 samples"),
    "correcting_lownoise": ("sins_sim.filters.wideband:build_lownoise",
                            "equalised second difference, flat to 1.5 kHz, band edge 2.2 kHz; delay 20 samples"),
    "lms_stripper": ("sins_sim.filters.lms_stripper:build_lms_stripper",
                     "production stripper (US 7,440,109): three pickoffs, E alpha_n + F alpha_{n-1} by normalised "
                     "LMS; delay 0"),
}
#: Shipped plug-ins that read the three axes together (built once per unit, not per axis).
THREE_AXIS = {"lms_stripper"}
#: Filters that use nothing of the suspension the run's ``filter_parameters`` describe: the truth, the readout, the
#: eliminator (a band-stop on the drive frequency alone) and the LMS stripper (it learns its gains from the pickoffs).
#: Every other filter is built from the believed f0 and k1..k5 (:class:`FilterContext`): eq. 5 in both forms and
#: the shipped wideband designs; a registered plug-in is assumed to use them unless ``register(...,
#: takes_parameters=False)``.
PARAMETER_FREE = {"ideal", "raw", "eliminator", "lms_stripper"}


def register(name: str, builder, description: str = "", three_axis: bool = False,
             takes_parameters: bool = True) -> None:
    """Make ``builder(ctx: FilterContext)`` selectable as filter ``name`` (``three_axis``: ``builder(ctx:
    ThreeAxisContext)``, see the module docstring). ``takes_parameters``: whether the filter uses the suspension
    parameters its context carries (:func:`takes_parameters`)."""
    if not isinstance(name, str) or not name.isidentifier():
        raise ValueError(f"filters.name: must be an identifier, got {name!r}")
    if name in BUILTIN_FILTERS:
        raise ValueError(f"filters.name: {name!r} is a built-in filter")
    if not callable(builder):
        raise ValueError(f"filters.{name}: the builder must be callable")
    _REGISTRY[name] = (builder, description)
    if three_axis:
        THREE_AXIS.add(name)
    else:
        THREE_AXIS.discard(name)
    if takes_parameters:
        PARAMETER_FREE.discard(name)
    else:
        PARAMETER_FREE.add(name)


def takes_parameters(name: str) -> bool:
    """Whether filter ``name`` is built from the suspension parameters the run believes (``filter_parameters``:
    f0 and k1..k5), so that their source (true, nominal, online, a diagnosis) changes its output."""
    if not is_known(name):
        raise ValueError(f"filters: unknown filter {name!r}; known: {', '.join(BUILTIN_FILTERS + plugin_names())}")
    return name not in PARAMETER_FREE


def parameter_filters() -> tuple:
    """Every known filter that takes parameters (:func:`takes_parameters`): the built-in ones first, then the
    plug-ins sorted."""
    return tuple(n for n in BUILTIN_FILTERS + plugin_names() if takes_parameters(n))


def is_three_axis(name: str) -> bool:
    """Whether plug-in ``name`` reads the three axes together."""
    return name in THREE_AXIS


def _entry(name: str):
    if name in _REGISTRY:
        return _REGISTRY[name]
    if name in _LAZY:
        target, description = _LAZY[name]
        module, func = target.split(":")
        builder = getattr(importlib.import_module(module), func)
        _REGISTRY[name] = (builder, description)
        return _REGISTRY[name]
    raise ValueError(f"filters: unknown filter {name!r}; known: {', '.join(BUILTIN_FILTERS + plugin_names())}")


def plugin_names() -> tuple:
    """Names of the registered plug-in filters (shipped and user-registered), sorted."""
    return tuple(sorted(set(_REGISTRY) | set(_LAZY)))


def shipped_plugin_names() -> tuple:
    """Names of the plug-ins shipped with sins-sim (those a reference lists), sorted."""
    return tuple(sorted(_LAZY))


def is_known(name: str) -> bool:
    return name in BUILTIN_FILTERS or name in _REGISTRY or name in _LAZY


def describe(name: str) -> str:
    """The one-line description of a plug-in."""
    if name in _LAZY and name not in _REGISTRY:
        return _LAZY[name][1]
    return _entry(name)[1]


def build(name: str, ctx):
    """A fresh instance of plug-in ``name`` for one axis (``ctx``: FilterContext) or, for a three-axis plug-in, for
    the unit (``ctx``: ThreeAxisContext), checked for the protocol."""
    builder, _ = _entry(name)
    if is_three_axis(name) != hasattr(ctx, "axes"):
        raise ValueError(f"filters.{name}: a {'three-axis' if is_three_axis(name) else 'single-axis'} filter; "
                         f"{'only the SINS engine runs it' if is_three_axis(name) else 'built per axis'}")
    flt = builder(ctx)
    for attr in ("process", "reset", "delay_samples"):
        if not hasattr(flt, attr):
            raise ValueError(f"filters.{name}: the filter has no {attr!r} (see sins_sim.filters.registry)")
    return flt
