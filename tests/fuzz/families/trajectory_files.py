"""Trajectory files as real logs write them, and the date line and the poles (issue 25, items 1, 8 and 9).

``realistic_noise``: a flight (speed change, a turn, a climb) integrated on WGS-84 at 1 kHz and written like a
flight log: latitude and longitude to 5-8 decimals, heights to 1 cm, GNSS-grade velocity noise of 0.01-0.1 m/s
RMS (to 1 mm/s), time stamps at 1-20 Hz with jitter inside the file rule (strictly increasing, steps <= 1 s);
valid. One in five has velocity columns that contradict the positions (the sign of the east velocity flipped on an
easterly track, or of the down velocity in a climb of 3-8 m/s): invalid, refused naming the row and the column.

``date_line_pole``: segment flights and files crossing the antimeridian, near the poles (valid: within 89.5 deg),
and at or past the NED mechanisation's 89.5 deg limit (invalid: the file's row and ``lat_deg``, or
``site.lat_deg`` / ``trajectory.segments`` up front).
"""

from __future__ import annotations

import math
import random
from pathlib import Path

import numpy as np
import yaml

from . import Family, Made

IMU = {"channels": {"x": {"f0_hz": 386.0}, "y": {"f0_hz": 352.0}, "z": {"f0_hz": 421.0}}}
_A, _E2, _G = 6378137.0, 0.00669437999014, 9.80665
HEADER = ["time_s", "lat_deg", "lon_deg", "height_m", "roll_deg", "pitch_deg", "yaw_deg"]


def _flight(rng: random.Random, lat0, lon0, h0, seconds, speed=None, heading=None, turn=None, climb=None,
            dv=None):
    """A smooth flight on WGS-84: 1 kHz trapezoid (Heun) integration of lat, lon, h from the NED velocity.

    Returns a function of the sample times giving (lat, lon (unwrapped), h deg/m, roll, pitch, yaw deg,
    v_ned (n, 3) m/s)."""
    dt = 1e-3
    t = np.arange(0.0, seconds + 2 * dt, dt)
    s = np.sin(np.pi * np.clip(t / seconds, 0.0, 1.0)) ** 2  # 0 -> 1 -> 0 over the file
    ramp = np.clip(t / seconds, 0.0, 1.0)
    speed = rng.uniform(40.0, 250.0) if speed is None else speed
    dv = rng.uniform(-20.0, 20.0) if dv is None else dv
    v = speed + dv * (ramp - np.sin(2 * np.pi * ramp) / (2 * np.pi))  # smooth speed change
    rate = math.radians(rng.uniform(-6.0, 6.0) if turn is None else turn) * s
    psi = math.radians(rng.uniform(0.0, 360.0) if heading is None else heading) + np.cumsum(rate) * dt
    c = (rng.uniform(-8.0, 8.0) if climb is None else climb) * s
    vn, ve, vd = v * np.cos(psi), v * np.sin(psi), -c
    lat = np.empty_like(t)
    lon = np.empty_like(t)
    h = np.empty_like(t)
    lat[0], lon[0], h[0] = math.radians(lat0), math.radians(lon0), h0

    def rates(la, hh, k):
        w = np.sqrt(1.0 - _E2 * np.sin(la) ** 2)
        return vn[k] / (_A * (1 - _E2) / w ** 3 + hh), ve[k] / ((_A / w + hh) * np.cos(la))

    for k in range(t.size - 1):
        a1, o1 = rates(lat[k], h[k], k)
        hp = h[k] + dt * c[k]
        a2, o2 = rates(lat[k] + dt * a1, hp, k + 1)
        lat[k + 1] = lat[k] + 0.5 * dt * (a1 + a2)
        lon[k + 1] = lon[k] + 0.5 * dt * (o1 + o2)
        h[k + 1] = h[k] + 0.5 * dt * (c[k] + c[k + 1])
    dpsi = np.gradient(psi, dt)
    roll = np.degrees(np.arctan(v * dpsi / _G))
    pitch = np.degrees(np.arctan2(c, v))
    yaw = (np.degrees(psi) + 180.0) % 360.0 - 180.0

    def at(ts):
        idx = np.clip(np.round(ts / dt).astype(int), 0, t.size - 1)
        frac = ts / dt - idx  # sub-millisecond remainder: linear correction of the position
        la = lat[idx] + frac * dt * rates(lat[idx], h[idx], idx)[0]
        lo = lon[idx] + frac * dt * rates(lat[idx], h[idx], idx)[1]
        hh = h[idx] + frac * dt * c[idx]
        return (np.degrees(la), np.degrees(lo), hh, roll[idx], pitch[idx], yaw[idx],
                np.stack((vn[idx], ve[idx], vd[idx]), axis=-1))

    return at


def _times(rng: random.Random, seconds, rate_hz, jitter=True):
    n = int(seconds * rate_hz) + 1
    t = np.arange(n) / rate_hz
    amp = min(0.2 / rate_hz, 0.5 * (1.0 - 1.0 / rate_hz))  # up to 20 % of a step: increasing, steps <= 1 s
    if jitter and amp > 0.0:
        t[1:-1] += rng.uniform(0.0, amp) * np.array([rng.uniform(-1.0, 1.0) for _ in range(n - 2)])
    return t


def _csv(t, lat, lon, h, roll, pitch, yaw, vel, dec_t=3, dec_ll=13, dec_h=8, dec_v=6, lon_wrap=True) -> bytes:
    if lon_wrap:
        lon = (lon + 180.0) % 360.0 - 180.0
    header = HEADER + (["vn_m_s", "ve_m_s", "vd_m_s"] if vel is not None else [])
    lines = [",".join(header)]
    for k in range(t.size):
        row = [f"{t[k]:.{dec_t}f}", f"{lat[k]:.{dec_ll}f}", f"{lon[k]:.{dec_ll}f}", f"{h[k]:.{dec_h}f}",
               f"{roll[k]:.6f}", f"{pitch[k]:.6f}", f"{yaw[k]:.6f}"]
        if vel is not None:
            row += [f"{x:.{dec_v}f}" for x in vel[k]]
        lines.append(",".join(row))
    return ("\n".join(lines) + "\n").encode()


def _scenario(trajectory: dict, site: dict | None = None, duration_s: float = 1.3, seed: int = 0) -> bytes:
    doc = {"name": "traj-real", "seed": seed, "duration_s": duration_s, "imu": IMU, "trajectory": trajectory,
           "navigation": {"start_s": 1.0}, "outputs": {"plots": False, "timeseries": False}}
    if site is not None:
        doc["site"] = site
    return yaml.safe_dump(doc).encode()


def _file_case(cls, expect, what, csv: bytes, seed: int) -> Made:
    return Made(cls, expect, what, {"trajectory.csv": csv, "scenario.yaml": _scenario({"file": "trajectory.csv"},
                                                                                      seed=seed)}, "trajectory.csv")


def _realistic(rng: random.Random) -> Made:
    seconds = rng.choice([3.0, 5.0, 10.0, 20.0])
    rate = rng.choice([1.0, 2.0, 5.0, 10.0, 20.0]) if seconds >= 5.0 else rng.choice([2.0, 5.0, 10.0, 20.0])
    dec_ll = rng.choice([5, 6, 7, 8])
    noise = rng.uniform(0.01, 0.1)
    bad = rng.random() < 0.2
    how = rng.choice(["flip_east", "flip_down"]) if bad else ""
    # a flipped east velocity is then ~ the whole speed (>= 35 m/s); a flipped climb rate up to 2 x 3-8 m/s
    heading = rng.uniform(60.0, 120.0) if how == "flip_east" else None
    climb = rng.choice([-1.0, 1.0]) * rng.uniform(3.0, 8.0) if how == "flip_down" else None
    fl = _flight(rng, rng.uniform(-70.0, 70.0), rng.uniform(-180.0, 180.0), rng.uniform(0.0, 10000.0), seconds + 0.5,
                 heading=heading, climb=climb)
    t = _times(rng, seconds, rate)
    lat, lon, h, roll, pitch, yaw, vel = fl(t)
    nrng = np.random.default_rng(rng.randrange(2 ** 32))
    vel = vel + noise * nrng.standard_normal(vel.shape)
    what = (f"log: {rate:g} Hz with jitter, {seconds:g} s, lat/lon to {dec_ll} decimals, heights to 1 cm, velocity "
            f"noise {noise:.3f} m/s")
    if bad:
        vel[:, 1 if how == "flip_east" else 2] *= -1.0
        what += f", {'east' if how == 'flip_east' else 'down'} velocity's sign flipped"
    csv = _csv(t, lat, lon, h, roll, pitch, yaw, vel, dec_t=rng.choice([3, 4, 6]), dec_ll=dec_ll, dec_h=2, dec_v=3)
    return _file_case("realistic_noise", "invalid" if bad else "valid", what, csv, rng.randrange(100))


def _date_line_pole(rng: random.Random) -> Made:
    cls = "date_line_pole"
    how = rng.choice(["seg_dateline", "seg_near_pole", "seg_site_past", "seg_reaches_pole", "file_dateline",
                      "file_near_pole", "file_at_pole", "file_reaches_pole"])
    seed = rng.randrange(100)
    north = rng.random() < 0.5
    sgn = 1.0 if north else -1.0
    if how.startswith("seg_"):
        if how == "seg_dateline":
            site = {"lat_deg": rng.uniform(-60.0, 60.0), "lon_deg": rng.choice([179.99, 179.999, -179.99]),
                    "height_m": 1000.0, "heading_deg": rng.choice([90.0, -90.0, 45.0, 270.0])}
            traj = {"speed_m_s": rng.uniform(100.0, 300.0), "transition_s": 0.5,
                    "segments": [{"type": "cruise", "duration_s": 3.0}]}
            return Made(cls, "valid", f"segments across the antimeridian from lon {site['lon_deg']}",
                        {"scenario.yaml": _scenario(traj, site, seed=seed)}, "scenario.yaml")
        if how == "seg_near_pole":  # 89 deg (the site's limit); 1.3 s at <= 300 m/s is < 0.004 deg
            site = {"lat_deg": sgn * 89.0, "lon_deg": rng.uniform(-180.0, 180.0), "height_m": 500.0,
                    "heading_deg": rng.uniform(0.0, 360.0)}
            traj = {"speed_m_s": rng.uniform(0.0, 300.0), "transition_s": 0.5,
                    "segments": [{"type": "turn", "duration_s": 3.0, "heading_change_deg": 30.0}]}
            return Made(cls, "valid", f"segments at lat {site['lat_deg']:g}",
                        {"scenario.yaml": _scenario(traj, site, seed=seed)}, "scenario.yaml")
        if how == "seg_site_past":
            lat = sgn * rng.choice([89.2, 89.6, 89.9, 90.0])
            site = {"lat_deg": lat, "lon_deg": 0.0, "height_m": 0.0, "heading_deg": 0.0}
            return Made(cls, "invalid", f"site at lat {lat:g}", {"scenario.yaml": _scenario({}, site, seed=seed)},
                        "scenario.yaml")
        # from 89 deg towards the pole at 3000 m/s: past 89.5 deg after ~18.5 s of a 30 s run
        site = {"lat_deg": sgn * 89.0, "lon_deg": 10.0, "height_m": 1000.0, "heading_deg": 0.0 if north else 180.0}
        traj = {"speed_m_s": 3000.0, "segments": [{"type": "cruise", "duration_s": 40.0}]}
        return Made(cls, "invalid", "segments flying past 89.5 deg", {"scenario.yaml": _scenario(traj, site, 30.0,
                                                                                                   seed)},
                    "scenario.yaml")
    seconds, rate = 3.0, rng.choice([10.0, 20.0])
    with_v = rng.random() < 0.5
    if how == "file_dateline":
        fl = _flight(rng, rng.uniform(-60.0, 60.0), 179.9995, 1000.0, seconds + 0.5, speed=250.0, heading=90.0,
                     turn=0.0)
        t = _times(rng, seconds, rate)
        lat, lon, h, roll, pitch, yaw, vel = fl(t)
        wrap = rng.random() < 0.5
        csv = _csv(t, lat, lon, h, roll, pitch, yaw, vel if with_v else None, lon_wrap=wrap)
        return _file_case(cls, "valid", f"file across the antimeridian ({'wrapped to -180' if wrap else 'past 180'}"
                                        f"{', velocity' if with_v else ''})", csv, seed)
    if how == "file_near_pole":  # 89.0-89.45 deg, 3 s at <= 100 m/s: < 0.003 deg of latitude
        lat0 = sgn * rng.uniform(89.0, 89.45)
        fl = _flight(rng, lat0, rng.uniform(-180.0, 180.0), 300.0, seconds + 0.5, speed=rng.uniform(20.0, 100.0),
                     turn=0.0)
        t = _times(rng, seconds, rate)
        lat, lon, h, roll, pitch, yaw, vel = fl(t)
        csv = _csv(t, lat, lon, h, roll, pitch, yaw, vel if with_v else None)
        return _file_case(cls, "valid", f"file at lat {lat0:.3f}{' with velocity' if with_v else ''}", csv, seed)
    if how == "file_at_pole":
        lat0 = sgn * rng.choice([89.6, 89.9, 90.0])
        fl = _flight(rng, sgn * 89.0, 0.0, 300.0, seconds + 0.5, speed=50.0, turn=0.0)
        t = _times(rng, seconds, rate)
        lat, lon, h, roll, pitch, yaw, vel = fl(t)
        lat = lat - lat[0] + lat0 - sgn * 1e-6 * np.arange(t.size)  # stays at the pole side of 89.5
        lat = np.clip(lat, -90.0, 90.0)
        csv = _csv(t, lat, lon, h, roll, pitch, yaw, None)
        return _file_case(cls, "invalid", f"file at lat {lat0:g}", csv, seed)
    # from 89.499 deg towards the pole at 250 m/s: 89.5 deg after ~0.4 s
    fl = _flight(rng, sgn * 89.499, 30.0, 300.0, seconds + 0.5, speed=250.0, heading=0.0 if north else 180.0,
                 turn=0.0, climb=0.0, dv=0.0)
    t = _times(rng, seconds, rate)
    lat, lon, h, roll, pitch, yaw, vel = fl(t)
    csv = _csv(t, lat, lon, h, roll, pitch, yaw, vel if with_v else None)
    return _file_case(cls, "invalid", "file reaching 89.5 deg", csv, seed)


def _make(rng: random.Random) -> Made:
    return _realistic(rng) if rng.random() < 0.5 else _date_line_pole(rng)


def _validate(folder: Path) -> None:
    from sins_sim.config.scenario import load_scenario
    from sins_sim.jobs.estimate import check_run

    check_run(load_scenario(folder / "scenario.yaml"))


FAMILY = Family(kind="trajectory_real", weight=0.04, classes=("realistic_noise", "date_line_pole"), make=_make,
                command=lambda folder: ["run", str(folder / "scenario.yaml"), "--out", str(folder / "out"), "--quiet"],
                validate=_validate)
