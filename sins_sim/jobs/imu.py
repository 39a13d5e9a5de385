"""IMU configuration files (``configs/*.yaml``) -> :class:`ImuConfig`.

Layout (every key optional except ``channels``; units in the key names)::

    name: default
    suspension: {k1: 1.75e-4, k2_rad: 1.05e-3, k3: 4.4e-3, k4_per_rad: 250, k5_rad_per_v: -1.2e-5}
    drive: {amplitude_arcmin: 3.0, dac_rate_hz: 72000, control: closed_loop, loop_time_s: 0.1,
            block_cycles: 10, modulation_depth: 0.0}
    plant: {rate_hz: 72000, hysteresis: paper}
    readout: {quantum_arcsec: 0.15125, noise_arcsec: 0.0, output_rate_hz: 7200,
              anti_alias: {cutoff_hz: 9000, numtaps: 21}}      # anti_alias: null = off
    correcting: {hysteresis: paper}
    eliminator: {width_hz: 40, rp_db: 0.1, rs_db: 60}
    channels:
      x: {f0_hz: 386}
      y: {f0_hz: 352, suspension: {k3: 4.6e-3}}
      z: {f0_hz: 421, drive: {amplitude_arcmin: 2.9}}

A channel's ``suspension`` and ``drive`` entries override the shared ones.
"""

from __future__ import annotations

from sins_sim.models.drive import DriveParams
from sins_sim.models.plant import PlantSettings
from sins_sim.models.readout import AntiAliasParams, ReadoutParams
from sins_sim.models.suspension import SuspensionParams
from sins_sim.jobs.schema import ConfigError, Map, Num, Str, validate
from sins_sim.jobs.yaml_io import load_yaml  # re-exported: other modules import it from here
from sins_sim.simulation.channel import ChannelConfig, EliminatorSettings
from sins_sim.simulation.sins import DriveControl, ImuConfig

__all__ = ["IMU_SCHEMA", "load_yaml", "load_imu", "imu_from_dict"]


def _suspension_fields(defaults: bool):
    d = (lambda x: x) if defaults else (lambda x: None)
    return {
        "k1": Num(min=0.0, default=d(1.75e-4), doc="eq. 9 scale"),
        "k2": Num(unit="rad", min=0.0, min_exclusive=True, default=d(1.05e-3), doc="eq. 9 angle"),
        "k3": Num(min=0.0, default=d(4.4e-3), doc="eq. 10 dissipation"),
        "k4": Num(unit="per_rad", default=d(250.0), doc="eq. 10 amplitude dependence"),
        "k5": Num(unit="rad_per_v", nonzero=True, default=d(-1.2e-5), doc="eq. 14 piezo gain"),
        "zeta": Num(min=0.0, default=d(0.0), doc="extra viscous damping ratio"),
    }


def _drive_fields(defaults: bool):
    d = (lambda x: x) if defaults else (lambda x: None)
    return {"amplitude": Num(unit="arcmin", min=0.0, min_exclusive=True, default=d(3.0))}


IMU_SCHEMA = Map({
    "name": Str(default="imu"),
    "description": Str(default=""),
    "suspension": Map(_suspension_fields(True), default={}),
    "drive": Map({
        **_drive_fields(True),
        "dac_rate": Num(unit="hz", min=0.0, min_exclusive=True, default=72000.0),
        "control": Str(choices=("open_loop", "closed_loop"), default="closed_loop"),
        "loop_time": Num(unit="s", min=0.0, min_exclusive=True, default=0.1),
        "block_cycles": Num(min=1, integer=True, default=10),
        "modulation_depth": Num(min=0.0, max=0.5, default=0.0),
    }, default={}),
    "plant": Map({
        "rate": Num(unit="hz", min=0.0, min_exclusive=True, default=72000.0),
        "hysteresis": Str(choices=("paper", "masing"), default="paper"),
    }, default={}),
    "readout": Map({
        "quantum": Num(unit="arcsec", min=0.0, min_exclusive=True, default=2.42 / 16),
        "noise": Num(unit="arcsec", min=0.0, default=0.0),
        "output_rate": Num(unit="hz", min=0.0, min_exclusive=True, default=7200.0),
        "anti_alias": Map({
            "cutoff": Num(unit="hz", min=0.0, min_exclusive=True, default=9000.0),
            "numtaps": Num(min=1, integer=True, default=21),
        }, default={}, allow_null=True),
    }, default={}),
    "correcting": Map({"hysteresis": Str(choices=("paper", "masing"), default="paper")}, default={}),
    "eliminator": Map({
        "width": Num(unit="hz", min=0.0, min_exclusive=True, default=40.0),
        "rp": Num(unit="db", min=0.0, min_exclusive=True, default=0.1),
        "rs": Num(unit="db", min=0.0, min_exclusive=True, default=60.0),
    }, default={}),
    "channels": Map({
        axis: Map({
            "f0": Num(unit="hz", min=0.0, min_exclusive=True, required=True),
            "suspension": Map(_suspension_fields(False), default={}),
            "drive": Map(_drive_fields(False), default={}),
        }, required=True) for axis in ("x", "y", "z")
    }, required=True),
})


def _merged(shared: dict, own: dict) -> dict:
    return {k: (own[k] if own.get(k) is not None else shared[k]) for k in shared}


def imu_from_dict(doc: dict, ctx: str, path: str = "") -> ImuConfig:
    """Validate an IMU mapping and build the ImuConfig (errors name ``ctx`` and the key path)."""
    c = validate(doc, IMU_SCHEMA, ctx, path)
    ro = c["readout"]
    anti = ro["anti_alias"]
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
                               modulation_depth=c["drive"]["modulation_depth"])
        channels = []
        for axis in ("x", "y", "z"):
            ch = c["channels"][axis]
            sus = _merged(c["suspension"], ch["suspension"])
            drv = _merged({"amplitude_rad": c["drive"]["amplitude_rad"]}, ch["drive"])
            suspension = SuspensionParams(f0_hz=ch["f0_hz"], k1=sus["k1"], k2=sus["k2_rad"], k3=sus["k3"],
                                          k4=sus["k4_per_rad"], k5=sus["k5_rad_per_v"], zeta=sus["zeta"])
            channels.append(ChannelConfig(
                suspension=suspension,
                drive=DriveParams(amplitude_rad=drv["amplitude_rad"], dac_rate_hz=c["drive"]["dac_rate_hz"]),
                plant=plant, readout=readout, filter_hysteresis=c["correcting"]["hysteresis"], eliminator=elim))
        return ImuConfig(channels=tuple(channels), drive_control=control, name=c["name"])
    except ConfigError:
        raise
    except ValueError as exc:  # a physical rule that needs several fields (Q > 0, fs > 2 f0, ...)
        raise ConfigError(f"{ctx}: {path + ': ' if path else ''}{exc}") from None


def load_imu(path) -> ImuConfig:
    """Load and validate an IMU file (``configs/*.yaml``).

    Parameters
    ----------
    path : path
        The YAML file: suspension, drive, plant, readout, filters and per-axis channels (the keys
        carry their units; see ``configs/default-imu.yaml``).

    Returns
    -------
    ImuConfig

    Raises
    ------
    ConfigError
        One line naming the file, the key path and the rule.
    """
    return imu_from_dict(load_yaml(path), str(path))


