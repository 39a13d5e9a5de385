"""Diagnosis inputs (issue 25, items 5, 6 and 10): recordings missing what their experiment needs, and recordings
that push the refit to its bounds.

``missing_experiment_key`` (invalid: refused naming the key): a rate-table recording without ``sins_angle``; a
recording shorter than the held-out test needs (``counts``); a header without one of its required keys.

``fit_at_bounds`` (valid: ``diagnose`` writes its JSON and report, whatever the status): a simulated recording
mutated as the outside campaign did (the nominal f0 a few per cent off, the sample rate halved, the quantum x16,
the axes permuted, ``sins_angle`` reversed), and clean recordings with an effect or disturbance switched on.
The base recordings are simulated once per process (0.3 s, one or two axes) and mutated per case.
"""

from __future__ import annotations

import functools
import io
import random
import tempfile
import warnings
from pathlib import Path

from . import Family, Made

EFFECTS = ({"name": "piezo_lag", "tau_s": 1.5e-4}, {"name": "lock_in", "threshold_rad_s": 2e-3},
           {"name": "resonance_drift", "rate_hz_per_s": 0.5}, {"name": "readout_delay", "delay_s": 3e-5},
           {"name": "mount_mode", "frequency_hz": 2200.0, "rms_rad": 2e-5, "seed": 3},
           {"name": "mains_pickup", "amplitude_rad": 4e-6, "frequency_hz": 50.0})
MUTATIONS = ("nominal f0 off", "sample rate halved", "quantum x16", "axes permuted", "sins_angle reversed")
META_KEYS = ("fs_hz", "quantum_rad", "nominal", "experiment", "initial_state", "axes")


@functools.lru_cache(maxsize=16)
def _base(experiment: str, n_axes: int, effect: int = -1, seed: int = 0):
    from sins_sim.config.experiment import experiment_from_dict
    from sins_sim.simulation.experiment import record

    doc = {"experiment": experiment, "axes": ["x", "y"][:n_axes], "duration_s": 0.3, "seed": seed,
           "perturb": {"f0": 0.001, "k": 0.03}, "noise_arcsec": 0.02}
    if effect >= 0:
        doc["effects"] = [dict(EFFECTS[effect])]
    spec = experiment_from_dict(doc)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return record(spec["inputs"], spec["truth"], spec["nominal"], spec["quantum_rad"], spec["effects"],
                      spec["settings"], noise_rad=spec["noise_rad"], seed=spec["seed"], experiment=experiment)


def _npz(meta, counts, drive, sins) -> bytes:
    """A recording's file as bytes, written by the format's own writer when the header is complete."""
    import numpy as np

    from sins_sim.io.recording import Recording, write_recording

    try:
        rec = Recording(meta, counts, drive, sins, {}, "case")
    except ValueError:
        rec = None
    if rec is not None:
        with tempfile.TemporaryDirectory() as tmp:
            p = write_recording(Path(tmp) / "rec.npz", rec)
            return Path(p).read_bytes()
    # a header the format refuses (a required key removed): written as the archive the reader reads
    import json

    buf = io.BytesIO()
    arrays = {"meta": np.array(json.dumps(meta)), "counts": counts, "drive_v": drive}  # the format's 0-d string
    if sins is not None:
        arrays["sins_angle"] = sins
    np.savez_compressed(buf, **arrays)
    return buf.getvalue()


def _missing(rng: random.Random) -> Made:
    which = rng.choice(["sins_angle", "short", "meta"])
    if which == "sins_angle":
        rec = _base("rate_table", rng.choice([1, 2]))
        meta = {k: v for k, v in rec.meta.items() if k != "sins_fs_hz"}
        return Made("missing_experiment_key", "invalid", "rate_table recording without sins_angle",
                    {"rec.npz": _npz(meta, rec.counts, rec.drive_v, None)}, "rec.npz")
    if which == "short":
        rec = _base(rng.choice(["stationary", "rate_table"]), 1)
        n = rng.choice([4, 5, 20, 100, 721, 1440])
        sins = None if rec.sins_angle is None else rec.sins_angle[:n]
        return Made("missing_experiment_key", "invalid", f"{rec.experiment} recording of {n} samples",
                    {"rec.npz": _npz(dict(rec.meta), rec.counts[:n], rec.drive_v[:n], sins)}, "rec.npz")
    rec = _base("stationary", 1)
    key = rng.choice(META_KEYS)
    meta = {k: v for k, v in rec.meta.items() if k != key}
    return Made("missing_experiment_key", "invalid", f"header without {key}",
                {"rec.npz": _npz(meta, rec.counts, rec.drive_v, rec.sins_angle)}, "rec.npz")


def _mutate(rec, name: str):
    meta = dict(rec.meta)
    sins = rec.sins_angle
    if name == "nominal f0 off":
        meta["nominal"] = {a: {**v, "f0_hz": v["f0_hz"] * 1.05} for a, v in meta["nominal"].items()}
    elif name == "sample rate halved":
        meta.update(fs_hz=rec.fs_hz / 2, drive_fs_hz=meta["drive_fs_hz"] / 2)
        if "sins_fs_hz" in meta:
            meta["sins_fs_hz"] = meta["sins_fs_hz"] / 2
    elif name == "quantum x16":
        meta["quantum_rad"] = rec.quantum_rad * 16
    elif name == "axes permuted":
        meta["axes"] = list(rec.axes)[::-1]
    elif name == "sins_angle reversed" and sins is not None:
        sins = sins[::-1].copy()
    return meta, sins


def _at_bounds(rng: random.Random) -> Made:
    if rng.random() < 0.6:
        name = rng.choice(MUTATIONS)
        experiment = "rate_table" if name == "sins_angle reversed" else rng.choice(["stationary", "rate_table"])
        n_axes = 2 if name == "axes permuted" else rng.choice([1, 2])
        rec = _base(experiment, n_axes)
        meta, sins = _mutate(rec, name)
        what = f"{experiment} recording on {n_axes} axis/axes, {name}"
    else:
        k = rng.randrange(len(EFFECTS))
        experiment = rng.choice(["stationary", "rate_table"])
        rec = _base(experiment, rng.choice([1, 2]), k)
        meta, sins = dict(rec.meta), rec.sins_angle
        what = f"{experiment} recording with {EFFECTS[k]['name']}"
    return Made("fit_at_bounds", "valid", what, {"rec.npz": _npz(meta, rec.counts, rec.drive_v, sins)}, "rec.npz")


def _make(rng: random.Random) -> Made:
    return _missing(rng) if rng.random() < 0.4 else _at_bounds(rng)


def _validate(folder: Path) -> None:
    """What ``diagnose`` checks before it fits: the reader, the experiment's requirements, the nominal units."""
    from sins_sim.identification.checks import require_inputs
    from sins_sim.io.recording import read_recording
    from sins_sim.simulation.experiment import suspension_from_nominal

    rec = read_recording(folder / "rec.npz")
    for a in rec.axes:
        suspension_from_nominal(rec.nominal[a])
    require_inputs(rec)


FAMILY = Family(kind="diagnosis", weight=0.03, classes=("missing_experiment_key", "fit_at_bounds"), make=_make,
                command=lambda folder: ["diagnose", str(folder / "rec.npz"), "--json", str(folder / "out.json"),
                                        "--report", str(folder / "report")],
                validate=_validate)
