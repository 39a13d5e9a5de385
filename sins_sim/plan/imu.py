"""The unit resolved: an IMU file's validated keys -> the engine's :class:`~sins_sim.simulation.sins.ImuConfig`.

:mod:`sins_sim.config.imu` checks the file's keys, units, ranges and rates (:func:`~sins_sim.config.imu.parse_imu`)
without importing a model; :func:`resolve_imu` builds the unit from what it returns: the suspensions and drives
(each channel's resolution at the plant rate, its drive frequency, its eliminator and eq. 5 designs), the
suspension each filter believes (``filter_parameters``: the file's, a diagnosis', the PLL's inversion, the online
estimator), the block on its isolators and what it refuses beside it, the pickoff triad and the LMS stripper.
A unit that cannot be built is refused with one :class:`~sins_sim.plan.errors.PlanError` line naming the key.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np

from sins_sim.plan.errors import PlanError

__all__ = ["resolve_imu", "filter_suspensions", "filters_used", "block_from_section", "check_block_effects"]

_K_KEYS = (("k1", "k1"), ("k2_rad", "k2"), ("k3", "k3"), ("k4_per_rad", "k4"), ("k5_rad_per_v", "k5"))


def resolve_imu(parsed: dict):
    """The unit of a parsed IMU file (:func:`sins_sim.config.imu.parse_imu`) as the engine runs it.

    Parameters
    ----------
    parsed : dict
        ``c`` (the validated mapping, SI keys), ``fspec`` (the parsed ``filter_parameters``), ``sensors``
        (the ``sensors:`` section, or ``None`` without one: ``has_sensors`` tells them apart), ``ctx`` (how
        messages name the file), ``path`` (the section's key path, ``""`` at the top) and ``base_dir``
        (where a diagnosis file named in ``filter_parameters`` is taken from).

    Returns
    -------
    ImuConfig

    Raises
    ------
    PlanError
        One line naming the file, the key and the rule.
    """
    c, fspec, ctx, path, base_dir = parsed["c"], parsed["fspec"], parsed["ctx"], parsed["path"], parsed["base_dir"]
    pre = f"{path + '.' if path else ''}"
    ro = c["readout"]
    anti = ro["anti_alias"]
    from sins_sim.models.drive import DriveParams
    from sins_sim.models.plant import PlantSettings, check_resolution
    from sins_sim.models.readout import AntiAliasParams, ReadoutParams
    from sins_sim.models.sensor_errors import sensor_params_from_dict
    from sins_sim.models.suspension import SuspensionParams
    from sins_sim.simulation.channel import ChannelConfig, EliminatorSettings
    from sins_sim.simulation.sins import DriveControl, ImuConfig

    sensors = None
    if parsed["has_sensors"]:
        try:
            sensors = sensor_params_from_dict(parsed["sensors"], ctx, f"{pre}sensors")
        except ValueError as exc:
            raise PlanError(f"{ctx}: {exc}" if not str(exc).startswith(ctx) else str(exc)) from None
    try:
        readout = ReadoutParams(
            quantum_rad=ro["quantum_rad"], noise_rad=ro["noise_rad"], input_rate_hz=c["plant"]["rate_hz"],
            output_rate_hz=ro["output_rate_hz"],
            anti_alias=None if anti is None else AntiAliasParams(cutoff_hz=anti["cutoff_hz"],
                                                                 numtaps=anti["numtaps"]))
        plant = PlantSettings(rate_hz=c["plant"]["rate_hz"], hysteresis=c["plant"]["hysteresis"])
        elim = EliminatorSettings(width_hz=c["eliminator"]["width_hz"], rp_db=c["eliminator"]["rp_db"],
                                  rs_db=c["eliminator"]["rs_db"])
        control = DriveControl(mode=c["drive"]["control"], loop_time_s=c["drive"]["loop_time_s"],
                               block_cycles=int(c["drive"]["block_cycles"]),
                               modulation_depth=c["drive"]["modulation_depth"],
                               modulation=c["drive"]["modulation"],
                               modulation_period_s=c["drive"]["modulation_period_s"])
        _check_shared(c, ctx, path)
        channels = []
        for axis in ("x", "y", "z"):
            where = f"{path + '.' if path else ''}channels.{axis}"
            try:
                ch = c["channels"][axis]
                sus = _merged(c["suspension"], ch["suspension"])
                drv = _merged({"amplitude_rad": c["drive"]["amplitude_rad"]}, ch["drive"])
                suspension = SuspensionParams(f0_hz=ch["f0_hz"], k1=sus["k1"], k2=sus["k2_rad"], k3=sus["k3"],
                                              k4=sus["k4_per_rad"], k5=sus["k5_rad_per_v"], zeta=sus["zeta"])
                check_resolution(suspension, plant.rate_hz)
                cfg = ChannelConfig(
                    suspension=suspension,
                    drive=DriveParams(amplitude_rad=drv["amplitude_rad"], dac_rate_hz=c["drive"]["dac_rate_hz"]),
                    plant=plant, readout=readout, filter_hysteresis=c["correcting"]["hysteresis"], eliminator=elim)
                cfg.eliminator_design().sos  # the band fits and the design is stable, checked before any kernel
                cfg.correcting_design("paper")
            except ValueError as exc:
                raise PlanError(f"{ctx}: {where}: {_user_keys(str(exc))}") from None
            channels.append(cfg)
        channels = _with_filter_parameters(channels, fspec, c, ctx, f"{pre}filter_parameters", base_dir)
        block = block_from_section(c["block"], ctx, f"{pre}block")  # its own PlanError
        if block is not None:
            check_block_effects(c["effects"] or (), ctx, pre)
            from sins_sim.models.block import check_block_resolution

            try:
                check_block_resolution(block, channels[0].plant.rate_hz)
            except ValueError as exc:
                raise PlanError(f"{ctx}: {pre}block.{exc}") from None
        pickoff, lms = _pickoff_and_lms(c, ro["output_rate_hz"], ctx, pre,
                                        tuple(ch.drive_signal().frequency_hz for ch in channels))
        try:
            return ImuConfig(channels=tuple(channels), drive_control=control, name=c["name"], sensors=sensors,
                             effects=c["effects"] or (), block=block, pickoff=pickoff,
                             filter_settings={"lms_stripper": lms})
        except ValueError as exc:  # an effect the engine cannot run (axis_coupling)
            raise PlanError(f"{ctx}: {pre}{exc}") from None
    except PlanError:
        raise
    except ValueError as exc:  # a physical rule that needs several fields (Q > 0, fs > 2 f0, ...)
        raise PlanError(f"{ctx}: {path + ': ' if path else ''}{_user_keys(str(exc))}") from None


def _merged(shared: dict, own: dict) -> dict:
    return {k: (own[k] if own.get(k) is not None else shared[k]) for k in shared}


def _check_shared(c: dict, ctx: str, path: str) -> None:
    """The shared suspension and drive must be physical on their own, even where every channel overrides them."""
    from sins_sim.models.drive import DriveParams
    from sins_sim.models.suspension import SuspensionParams

    sus, where = c["suspension"], f"{path + '.' if path else ''}suspension"
    try:
        shared = SuspensionParams(f0_hz=c["channels"]["x"]["f0_hz"], k1=sus["k1"], k2=sus["k2_rad"], k3=sus["k3"],
                                  k4=sus["k4_per_rad"], k5=sus["k5_rad_per_v"], zeta=sus["zeta"])
        DriveParams(amplitude_rad=c["drive"]["amplitude_rad"], dac_rate_hz=c["drive"]["dac_rate_hz"]).resolve(shared)
    except ValueError as exc:
        raise PlanError(f"{ctx}: {where} (shared, with channels.x.f0_hz): {_user_keys(str(exc))}") from None


#: Field names of the model objects -> the IMU file's keys, for messages: an error names the key the user wrote
#: (``readout.output_rate_hz: ... plant.rate_hz ...``, never the readout's internal ``input_rate_hz``).
_USER_KEYS = {
    "readout.input_rate_hz": "plant.rate_hz",
    "input_rate_hz": "plant.rate_hz",
    "readout.quantum_rad": "readout.quantum_arcsec",
    "readout.noise_rad": "readout.noise_arcsec",
    "drive.amplitude_rad": "drive.amplitude_arcmin",
    "suspension.k2": "suspension.k2_rad",
    "suspension.k4": "suspension.k4_per_rad",
    "suspension.k5": "suspension.k5_rad_per_v",
    "suspension.f0_hz": "f0_hz",
    "eliminator.band_hz": "eliminator.width_hz (the band centred on the dither)",
}


_USER_KEY_RE = re.compile(r"(?<![\w.])(" + "|".join(re.escape(k) for k in sorted(_USER_KEYS, key=len, reverse=True))
                          + r")(?![\w])")


def _user_keys(message: str) -> str:
    """``message`` with the model's field names replaced by the IMU file's keys (:data:`_USER_KEYS`)."""
    return _USER_KEY_RE.sub(lambda m: _USER_KEYS[m.group(1)], message)


def _pickoff_and_lms(c: dict, fs_hz: float, ctx: str, pre: str, dither_hz: tuple):
    """The pickoff triad and the LMS stripper's settings, checked as the engine will build them (one line naming
    the key otherwise)."""
    from sins_sim.filters.lms_stripper import LmsStripperDesign
    from sins_sim.models.pickoff import PickoffParams, PickoffTriadParams

    p = c["pickoff"]
    try:
        coil = PickoffParams(scale_v_per_rad_s=p["scale_v_per_rad_s"], gain_error=p["gain_error"], lag_s=p["lag_s"],
                             noise_v=p["noise_v"], rate_hz=c["plant"]["rate_hz"],
                             nonlinearity_per_rad2=p["nonlinearity_per_rad2"])
        triad = PickoffTriadParams(coils=(coil, coil, coil), coupling=tuple(tuple(r) for r in p["cross_coupling"]))
    except ValueError as exc:
        raise PlanError(f"{ctx}: {pre}{exc}") from None
    lms = dict(c["lms_stripper"])
    try:
        LmsStripperDesign(fs_hz=fs_hz, scale_v_per_rad_s=(coil.scale_v_per_rad_s,) * 3, dither_hz=dither_hz, **lms)
    except ValueError as exc:
        raise PlanError(f"{ctx}: {pre}{exc}") from None
    return triad, lms


def _with_filter_parameters(channels, fspec, c, ctx, where, base_dir):
    """The channels with the suspension their filters believe (``ChannelConfig.filter_suspension``)."""
    import dataclasses
    from pathlib import Path

    axes = ("x", "y", "z")
    sus = c["suspension"]
    nominal = {"k1": sus["k1"], "k2": sus["k2_rad"], "k3": sus["k3"], "k4": sus["k4_per_rad"], "k5": sus["k5_rad_per_v"]}
    believed = filter_suspensions(
        fspec, {a: ch.suspension for a, ch in zip(axes, channels)}, nominal,
        {a: c["channels"][a]["f0_hz"] for a in axes},
        {a: ch.drive_signal().frequency_hz for a, ch in zip(axes, channels)},
        {a: ch.drive.amplitude_rad for a, ch in zip(axes, channels)}, ctx,
        Path(base_dir) if base_dir is not None else None, where)
    online = {a: None for a in axes}
    if fspec["source"] == "online":
        from sins_sim.filters.online_estimator import OnlineSettings
        from sins_sim.simulation.online import OnlineSpec

        if c["drive"]["modulation_depth"] <= 0.0:
            raise PlanError(f"{ctx}: {where}.source: online learns from the amplitude modulation: needs "
                              f"drive.modulation_depth > 0, got {c['drive']['modulation_depth']!r}")
        o = fspec["online"]
        settings = OnlineSettings(forgetting_s=o["forgetting_s"], interval_cycles=int(o["interval_cycles"]),
                                  window_cycles=int(o["window_cycles"]), band=o["band"], k_prior=o["k_prior"],
                                  min_spread=o["min_spread"])
        for a in axes:
            online[a] = OnlineSpec(settings=settings, update_s=o["update_s"], smoothing_s=o["smoothing_s"],
                                   apply=True, datasheet={"f0_hz": c["channels"][a]["f0_hz"], **nominal})
    out = []
    for a, ch in zip(axes, channels):
        try:
            out.append(dataclasses.replace(ch, filter_suspension=believed[a], pll_tracking=bool(fspec["track"]),
                                           online=online[a]))
        except ValueError as exc:
            raise PlanError(f"{ctx}: {where} (axis {a}): {exc}") from None
    return out


def _read_diagnosis(path: Path, ctx: str, where: str) -> dict:
    try:
        doc = json.loads(path.read_text())
    except FileNotFoundError:
        raise PlanError(f"{ctx}: {where}: file not found: {path}") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise PlanError(f"{ctx}: {where}: not a readable diagnosis JSON ({type(exc).__name__}): {path}") from None
    try:
        params = doc["baseline"]["params"]
    except (KeyError, TypeError):
        raise PlanError(f"{ctx}: {where}: {path} has no baseline.params (is it a `sins-sim diagnose --json` "
                          f"file?)") from None
    if not isinstance(params, dict):
        raise PlanError(f"{ctx}: {where}: baseline.params must be a mapping of axes")
    return params


def filter_suspensions(spec: dict, true_by_axis: dict, nominal: dict, design_f0: dict, drive_hz: dict,
                       amplitude_rad: dict, ctx: str, base_dir: Path | None = None,
                       path: str = "filter_parameters") -> dict:
    """The suspension each axis's filters believe (axis -> SuspensionParams, or None for the truth itself).

    Parameters
    ----------
    spec : dict
        :func:`parse_filter_parameters` output.
    true_by_axis : dict axis -> SuspensionParams
        The unit's true suspensions.
    nominal : dict
        The shared (datasheet) ``k1, k2, k3, k4, k5`` (SI).
    design_f0 : dict axis -> float
        The channels' ``f0_hz`` in the IMU file (Hz).
    drive_hz, amplitude_rad : dict axis -> float
        Each drive's frequency (Hz) and target amplitude (rad): the PLL's lock point.
    """
    from sins_sim.models.suspension import SuspensionParams  # here: parsing a file stays light (no scipy, numba)

    src, f0_src, ppm = spec["source"], spec["f0"], spec["f0_mismatch_ppm"]
    if src == "true" and f0_src == "unit" and ppm == 0.0:
        return {a: None for a in true_by_axis}
    diag = None
    if src == "diagnose":
        p = Path(spec["file"])
        if base_dir is not None and not p.is_absolute():
            p = base_dir / p
        diag = _read_diagnosis(p, ctx, f"{path}.file")
    out = {}
    for axis, true in true_by_axis.items():
        where = f"{path} (axis {axis})"
        given_f0 = design_f0[axis]
        if src == "true":
            ks = {k: getattr(true, k) for k in ("k1", "k2", "k3", "k4", "k5")}
        elif src in ("nominal", "online"):  # online: the datasheet until the estimator has learnt
            ks = dict(nominal)
        elif src == "explicit":
            ks = dict(nominal)
            for key, attr in _K_KEYS:
                for block in (spec["suspension"], spec["channels"][axis]["suspension"]):
                    if block.get(key) is not None:
                        ks[attr] = block[key]
            given_f0 = spec["channels"][axis]["f0_hz"]
        else:
            row = diag.get(axis)
            if not isinstance(row, dict):
                raise PlanError(f"{ctx}: {path}.file: the diagnosis has no axis {axis!r} "
                                  f"(axes: {', '.join(map(str, diag))})")
            try:
                ks = {k: float(row[k]) for k in ("k1", "k2", "k3", "k4", "k5")}
                given_f0 = float(row["f0_hz"])
            except (KeyError, TypeError, ValueError):
                raise PlanError(f"{ctx}: {path}.file: baseline.params.{axis} must hold f0_hz, k1..k5 as "
                                  f"numbers") from None
        try:
            if f0_src == "unit":
                f0 = true.f0_hz
            elif f0_src == "given":
                f0 = given_f0
            else:
                # PLL: the drive is locked to F(a); the filter inverts F(a)/f0 with the k1, k2 it believes (eq. 9)
                probe = SuspensionParams(f0_hz=true.f0_hz, **ks)
                f0 = drive_hz[axis] * probe.f0_hz / probe.resonance_hz(amplitude_rad[axis])
            f0 *= 1.0 + 1e-6 * ppm
            if not math.isfinite(f0):
                raise ValueError(f"f0 not finite ({f0!r})")
            out[axis] = SuspensionParams(f0_hz=f0, zeta=true.zeta, **ks)
        except ValueError as exc:
            raise PlanError(f"{ctx}: {where}: {exc}") from None
    return out


#: eq. 5's two forms (``sins_sim.simulation.channel``): ``correcting`` is unity at DC, ``correcting_paper`` as printed.
_EQ5_FORMS = {"correcting": "unity", "correcting_paper": "paper"}


def filters_used(channels, spec: dict, filters, axes=("x", "y", "z")) -> dict:
    """The parameters each filter of a run actually used, per axis, in SI with the unit in the key.

    Parameters
    ----------
    channels : sequence of ChannelConfig
        The unit's channels as the run built them (``filter_suspension`` set by :func:`filter_suspensions`).
    spec : dict
        :func:`parse_filter_parameters` output (where the values came from).
    filters : sequence of str
        The run's filters.

    Returns
    -------
    dict
        ``filter -> axis -> {...}``. eq. 5 (``correcting``, ``correcting_paper``) and plug-ins: ``f0_hz``,
        ``k1``, ``k2_rad``, ``k3``, ``k4_per_rad``, ``k5_rad_per_v``, ``fs_hz``, ``hysteresis``, the unit's own
        ``unit_f0_hz`` and ``f0_error_ppm`` = (f0_hz / unit_f0_hz - 1) 1e6 (the mismatch the filter runs with,
        the PLL's inversion included), and the ``source``, ``f0_source``, ``f0_mismatch_ppm`` and ``track`` of
        ``filter_parameters``; ``eliminator``: the elliptic design (``band_hz``, ``order``, ``rp_db``,
        ``rs_db``, ``fs_hz``) centred on ``drive_hz``; ``ideal`` and ``raw``: nothing to believe (``{}``).
    """
    import dataclasses

    origin = {"source": spec["source"], "f0_source": spec["f0"], "f0_mismatch_ppm": float(spec["f0_mismatch_ppm"]),
              "track": bool(spec["track"])}
    out = {}
    for name in filters:
        per_axis = {}
        for axis, ch in zip(axes, channels):
            if name in ("ideal", "raw"):
                per_axis[axis] = {}
                continue
            if name == "eliminator":
                d = ch.eliminator_design()
                per_axis[axis] = {"band_hz": [float(x) for x in d.band_hz], "order": int(d.order),
                                  "rp_db": float(d.rp_db), "rs_db": float(d.rs_db), "fs_hz": float(d.fs_hz),
                                  "drive_hz": float(ch.drive_signal().frequency_hz)}
                continue
            if name in _EQ5_FORMS:
                b = dataclasses.asdict(ch.correcting_design(_EQ5_FORMS[name]))
            else:
                b = dataclasses.asdict(ch.filter_context(axis))
            unit_f0 = ch.suspension.f0_hz
            row = {"f0_hz": b["f0_hz"], "k1": b["k1"], "k2_rad": b["k2"], "k3": b["k3"], "k4_per_rad": b["k4"],
                   "k5_rad_per_v": b["k5"], "fs_hz": b["fs_hz"], "hysteresis": b["hysteresis"]}
            if "form" in b:
                row["form"] = b["form"]
            row.update(unit_f0_hz=unit_f0, f0_error_ppm=(b["f0_hz"] / unit_f0 - 1.0) * 1e6, **origin)
            per_axis[axis] = row
        out[name] = per_axis
    return out


def block_from_section(c: dict | None, ctx: str, path: str) -> BlockParams | None:
    """The validated ``block`` section (SI keys, :data:`BLOCK_SCHEMA`) as :class:`BlockParams`; None stays None."""
    from sins_sim.models.block import BlockParams  # the model (scipy) once the section has passed its schema

    if c is None:
        return None
    j = c["inertia_kg_m2"]
    tensor = np.array([[j["xx"], j["xy"], j["xz"]], [j["xy"], j["yy"], j["yz"]], [j["xz"], j["yz"], j["zz"]]])
    axes = np.eye(3)
    for i, a in enumerate(("x", "y", "z")):
        off = 1e-3 * np.asarray(c["gyro_axes_mrad"][a], dtype=float)  # mrad -> rad
        if off[i] != 0.0:
            raise PlanError(f"{ctx}: {path}.gyro_axes_mrad.{a}[{i}]: must be 0 (the offset of the {a} axis is "
                              f"across it), got {off[i] * 1e3:g}")
        axes[i] += off
    iso = c["isolators"]
    try:
        return BlockParams(mass_kg=c["mass_kg"], inertia_kg_m2=tensor, gyro_inertia_kg_m2=c["gyro_inertia_kg_m2"],
                           input_axes=axes, k_trans_n_per_m=iso["stiffness_n_per_m"],
                           c_trans_n_s_per_m=iso["damping_n_s_per_m"],
                           k_rot_n_m_per_rad=iso["rotational_stiffness_n_m_per_rad"],
                           c_rot_n_m_s_per_rad=iso["rotational_damping_n_m_s_per_rad"],
                           elastic_centre_m=iso["elastic_centre_m"])
    except ValueError as exc:
        msg = str(exc)
        key = {"input_axes": "gyro_axes_mrad"}
        for name, user in key.items():
            msg = msg.replace(f"{name}:", f"{user}:", 1) if msg.startswith(name) else msg
        raise PlanError(f"{ctx}: {path}.{msg}") from None


def check_block_effects(effects, ctx: str, pre: str = "") -> None:
    """A block on isolators with an effect that acts beyond the suspension: refused, naming both keys.

    The block's kernel steps the three suspensions and the block together on the fused path; the effect stages
    (``sins_sim.simulation.channel._EffectStages``: piezo lag, the block-mode filter, resonance drift, readout
    delay and scale, lock-in) run on each channel's own reference path, which has no block. ``block_mode`` would
    also count the mount twice. ``viscous_damping`` changes the suspension itself and composes.
    """
    for i, e in enumerate(effects):
        if getattr(e, "stage", "") != "suspension":
            raise PlanError(f"{ctx}: {pre}effects[{i}] ({e.name}) with {pre}block: not modelled together (the "
                              f"effect stages run on a channel's own path, which has no block on isolators; "
                              f"docs/user-guide/combinations.md): remove one")
