"""``sins-sim navigate INCREMENTS --truth TRAJECTORY`` (issue 40): the increments of an ideal IMU along a 3.9 s
level flight, then mutated: times off the truth, non-uniform, repeated, reversed; cells that are not numbers;
columns missing, unknown or renamed; increments beyond what an IMU measures (a rate beyond 1000 deg/s, a specific
force beyond 200 g, degrees for radians, 1e300). Each refusal names the column (and row) of the file."""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np

from . import Family, Made
from ._listed import pick

COLUMNS = ("time_s", "dtheta_x_rad", "dtheta_y_rad", "dtheta_z_rad", "dv_x_m_s", "dv_y_m_s", "dv_z_m_s")


@functools.lru_cache(maxsize=1)
def _base() -> tuple:
    """(truth CSV bytes, t, dtheta, dv): 300 increments at 100 Hz of an ideal IMU along the truth."""
    import tempfile

    from sins_sim.io import read_trajectory
    from sins_sim.models.motion import SampledTrajectory
    from sins_sim.simulation.external import ideal_increments

    from ..generate import _csv, _trajectory_rows

    truth = _csv(*_trajectory_rows(rows=40))
    with tempfile.TemporaryDirectory() as tmp:
        (Path(tmp) / "truth.csv").write_bytes(truth)
        vehicle = SampledTrajectory.from_data(read_trajectory(Path(tmp) / "truth.csv"))
    t = 0.01 * np.arange(1, 301)
    dth, dv = ideal_increments(vehicle, t)
    return truth, t, dth, dv


def _csv_rows(t, dth, dv, header=COLUMNS) -> bytes:
    rows = [",".join(header)] + [",".join(repr(float(x)) for x in (t[i], *dth[i], *dv[i])) for i in range(len(t))]
    return ("\n".join(rows) + "\n").encode()


def _case(cls, expect, what, edit):
    def make():
        truth, t, dth, dv = _base()
        t, dth, dv = t.copy(), dth.copy(), dv.copy()
        out = edit(t, dth, dv)
        data = out if isinstance(out, bytes) else _csv_rows(*(out or (t, dth, dv)))
        return Made(cls, expect, f"navigate: {what}", {"truth.csv": truth, "increments.csv": data}, "increments.csv")
    return make


def _set(arr, i, j, value):
    arr[i, j] = value


CASES = [
    _case("navigate_valid", "valid", "an ideal IMU's increments", lambda t, a, v: None),
    _case("navigate_valid", "valid", "the first 10 increments", lambda t, a, v: (t[:10], a[:10], v[:10])),
    _case("navigate_valid", "valid", "columns in another order",
          lambda t, a, v: _csv_rows(t, a[:, ::-1], v, ("time_s", "dtheta_z_rad", "dtheta_y_rad", "dtheta_x_rad",
                                                      "dv_x_m_s", "dv_y_m_s", "dv_z_m_s"))),
    _case("navigate_times", "invalid", "times past the truth's end", lambda t, a, v: (t + 3.5, a, v)),
    _case("navigate_times", "invalid", "times before the truth's start", lambda t, a, v: (t - 0.5, a, v)),
    _case("navigate_times", "invalid", "one time 3 ms late", lambda t, a, v: (np.where(np.arange(300) == 150, t + 0.003, t), a, v)),
    _case("navigate_times", "invalid", "a time repeated", lambda t, a, v: (np.where(np.arange(300) == 150, t[149], t), a, v)),
    _case("navigate_times", "invalid", "times reversed", lambda t, a, v: (t[::-1], a, v)),
    _case("navigate_times", "invalid", "times in ms", lambda t, a, v: (1000.0 * t, a, v)),
    _case("navigate_times", "invalid", "one row", lambda t, a, v: (t[:1], a[:1], v[:1])),
    _case("navigate_columns", "invalid", "no dv_z_m_s", lambda t, a, v: _csv_rows(t, a, v, COLUMNS[:6] + ("dv_z",))),
    _case("navigate_columns", "invalid", "a cell of text",
          lambda t, a, v: _csv_rows(t, a, v).replace(repr(float(a[5, 1])).encode(), b"abc", 1)),
    _case("navigate_columns", "invalid", "an empty file", lambda t, a, v: b""),
    _case("navigate_physical", "invalid", "dtheta x 1e300", lambda t, a, v: (t, a * 1e300, v)),
    _case("navigate_physical", "invalid", "a 2000 deg/s rate", lambda t, a, v: (t, a + np.radians(2000.0) * 0.01, v)),
    _case("navigate_physical", "invalid", "dtheta in degrees (a 50 deg/s turn)",
          lambda t, a, v: (t, np.degrees(a + np.radians(50.0) * 0.01), v)),
    _case("navigate_physical", "invalid", "dv in mm/s", lambda t, a, v: (t, a, 1000.0 * v)),
    _case("navigate_physical", "invalid", "one dv of 1e6", lambda t, a, v: (_set(v, 7, 0, 1.0e6), (t, a, v))[1]),
]


def _validate(folder: Path) -> None:
    """The whole command in-process (the navigation of 300 increments takes a fraction of a second)."""
    from sins_sim.jobs.navigate import navigate_file

    navigate_file(folder / "increments.csv", folder / "truth.csv", folder / "out")


FAMILY = Family(kind="navigate_inputs", weight=0.02,
                classes=("navigate_valid", "navigate_times", "navigate_columns", "navigate_physical"),
                make=lambda rng: pick(CASES, rng),
                command=lambda folder: ["navigate", str(folder / "increments.csv"), "--truth", str(folder / "truth.csv"),
                                        "--out", str(folder / "out")],
                validate=_validate)
