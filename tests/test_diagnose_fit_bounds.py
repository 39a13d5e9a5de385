"""The diagnosis never stops on its own fitted parameters (issue 25, item 10).

A simulated two-axis rate-table recording is mutated the ways the outside campaign found: the
header's nominal f0 5 % off, the sample rate halved (fs_hz, drive_fs_hz and sins_fs_hz), the readout
quantum x16, the axes permuted, ``sins_angle`` reversed in time. Before the fix the fit's trial
points left the ranges ``SuspensionParams`` accepts (``suspension.k4: must be in [-20, 10000] 1/rad``,
``k3 >= 0``) and the diagnosis stopped with that message. Now every mutation gives a JSON with a
status; every refit parameter is inside the model's physical range; and the data checks or the
plausibility flags say that the result is not to be trusted.
"""

from __future__ import annotations

import numpy as np
import pytest

from sins_sim.config.experiment import experiment_from_dict
from sins_sim.identification.diagnose import DiagnoseSettings, diagnose_recording
from sins_sim.identification.refit import physical_clip, physical_limits
from sins_sim.identification.verdict import STATUSES
from sins_sim.io.recording import NOMINAL_KEYS, Recording
from sins_sim.simulation.experiment import record

EFFECTS = ("piezo_lag", "viscous_damping", "lock_in")


@pytest.fixture(scope="module")
def base() -> Recording:
    spec = experiment_from_dict({"experiment": "rate_table", "axes": ["x", "y"], "duration_s": 0.4, "seed": 2,
                                 "integrator": "rk4", "perturb": {"f0": 0.001, "k": 0.03}, "noise_arcsec": 0.02})
    return record(spec["inputs"], spec["truth"], spec["nominal"], spec["quantum_rad"], [], spec["settings"],
                  noise_rad=spec["noise_rad"], seed=spec["seed"], experiment=spec["experiment"])


def _mutate(rec: Recording, name: str) -> Recording:
    meta = dict(rec.meta)
    sins = rec.sins_angle
    if name == "nominal f0 off":
        meta["nominal"] = {a: {**v, "f0_hz": v["f0_hz"] * 1.05} for a, v in meta["nominal"].items()}
    elif name == "sample rate halved":
        meta.update(fs_hz=rec.fs_hz / 2, drive_fs_hz=meta["drive_fs_hz"] / 2, sins_fs_hz=meta["sins_fs_hz"] / 2)
    elif name == "quantum x16":
        meta["quantum_rad"] = rec.quantum_rad * 16
    elif name == "axes permuted":
        meta["axes"] = list(rec.axes)[::-1]
    elif name == "sins_angle reversed":
        sins = rec.sins_angle[::-1].copy()
    return Recording(meta, rec.counts, rec.drive_v, sins, {}, name)


MUTATIONS = ("nominal f0 off", "sample rate halved", "quantum x16", "axes permuted", "sins_angle reversed")


def test_clip_projects_onto_the_physical_ranges():
    lim = physical_limits()
    inside = np.array([386.0, 1.75e-4, 1.05e-3, 4.4e-3, 250.0, -1.2e-5])
    assert np.array_equal(physical_clip(inside), inside)  # a unit inside its ranges is not touched
    f0, k1, k2, k3, k4, k5 = physical_clip([386.0, 5e-3, 1.05e-3, -4e-3, -82.5, -3.0])
    assert k1 < 2 * k2 and k3 == lim["k3"][0] and k4 == lim["k4"][0] and k5 == -lim["k5"][1]


@pytest.mark.parametrize("name", MUTATIONS)
def test_mutated_recordings_give_a_result_not_an_error(base, name):
    js = diagnose_recording(_mutate(base, name), DiagnoseSettings(effects=EFFECTS)).to_json()
    assert js["verdict"]["status"] in STATUSES
    if js["verdict"]["status"] == "invalid data":
        assert js["findings"] and all(f["check"] and f["axis"] for f in js["findings"])
        return
    lim = physical_limits()
    for fits in [js["baseline"]["params"]] + [c["nominal"] for c in js["candidates"]]:
        for p in fits.values():
            for k in NOMINAL_KEYS:
                val = abs(p[k]) if k == "k5" else p[k]
                assert lim[k][0] <= val <= lim[k][1], (k, p[k])
            assert p["k1"] < 2 * p["k2"]
    # the header does not describe the data: the result says it is not to be trusted
    assert js["flags"] or js["verdict"]["status"] == "unknown", js["verdict"]
