"""Sweep files with their population keys mutated (issue 25, items 4 and 11): bad means, widths and percentages,
draws over missing sections, unknown population keys, seeds in exponent form, and valid small sweeps of two runs
with tiny durations.

Every case is a folder with the sweep file, one scenario (0.05-0.2 s at rest, an inline IMU) and, where the case
draws sensor errors, a preset. The command runs the sweep on one local worker; a valid case must run, an invalid
one must be refused before any task, naming the sweep key (``population.<key>...``, ``seed``).
"""

from __future__ import annotations

import random
from pathlib import Path

import yaml

from . import Family, Made

IMU = {"channels": {"x": {"f0_hz": 386.0}, "y": {"f0_hz": 352.0}, "z": {"f0_hz": 421.0}}}
PRESET = {"sensors": {"gyro": {"bias_deg_h": 0.01, "scale_factor_ppm": 5.0, "misalignment_arcsec": 2.0},
                      "accelerometer": {"bias_ug": 50.0, "scale_factor_ppm": 100.0}}}
#: A preset whose sensors block has only a noise density and a zero 1-sigma value: a draw of it draws nothing.
PRESET_EMPTY = {"sensors": {"gyro": {"arw_deg_rt_h": 0.002, "bias_deg_h": 0.0}}}
CLASSES = ("population_valid", "population_bad_value", "population_draws_nothing", "population_unknown_key",
           "population_seed_form")
K_KEYS = ("k1_percent", "k2_percent", "k3_percent", "k4_percent", "k5_percent")


def _scenario(rng: random.Random) -> dict:
    duration = rng.choice([0.05, 0.1, 0.2])
    return {"name": "tiny", "seed": rng.randrange(1000), "duration_s": duration, "imu": IMU,
            "motion": [{"type": "static"}], "navigation": {"start_s": 0.0}, "filters": ["ideal", "correcting"]}


def _valid_population(rng: random.Random) -> tuple[dict, str]:
    pick = rng.choice(["f0_ppm", "f0_hz", "k", "temperature", "grid", "sensors"])
    if pick == "f0_ppm":
        return {"f0_ppm": {"distribution": rng.choice(["normal", "uniform"]), "width": rng.choice([10, 1000, 5000])}}, \
            "f0_ppm spread"
    if pick == "f0_hz":
        return {"f0_hz": {"mean": rng.choice([-2.0, 0.0, 3.5]), "width": 1.0}}, "f0_hz spread"
    if pick == "k":
        k = rng.choice(K_KEYS)
        return {k: {"distribution": "uniform", "mean": rng.choice([-20, 0, 30]), "width": rng.choice([1, 10])}}, \
            f"{k} spread"
    if pick == "temperature":
        return {"temperature_k": {"distribution": "uniform", "width": 30},
                "temperature_coefficient_ppm_per_k": {"mean": -30, "width": 5}}, "temperature pair"
    if pick == "grid":
        k = rng.choice(K_KEYS)
        return {k: {"distribution": "grid", "values": [-10, 10]}}, f"{k} grid"
    return {"sensors": {"draw": True, "preset": "preset.yaml"}}, "sensor draw from a preset with sigmas"


def _bad_value(rng: random.Random) -> tuple[dict, str, str]:
    """(population, what, the key the refusal must name)."""
    k = rng.choice(K_KEYS)
    options = [
        ({k: {"width": -1}}, f"{k}.width negative", f"population.{k}.width"),
        ({k: {"mean": rng.choice([-150, 250, 1e9])}}, f"{k}.mean out of range", f"population.{k}.mean"),
        ({"k5_percent": {"mean": -100}}, "k5_percent.mean -100 (k5 = 0)", "population.k5_percent.mean"),
        ({"f0_ppm": {"width": rng.choice([2e5 + 1, 1e12])}}, "f0_ppm.width beyond 20 %", "population.f0_ppm.width"),
        ({"f0_hz": {"mean": rng.choice([-101, float("nan")])}}, "f0_hz.mean out of range or nan",
         "population.f0_hz.mean"),
        ({k: {"width": "wide"}}, f"{k}.width not a number", f"population.{k}.width"),
        ({k: {"distribution": "grid", "values": [0, -100.5]}}, f"{k} grid value below -100 %",
         f"population.{k}.values"),
        ({"temperature_k": {"width": 1000}, "temperature_coefficient_ppm_per_k": {"width": 1}},
         "temperature_k.width beyond 100 K", "population.temperature_k.width"),
        ({k: {"distribution": "lognormal", "width": 1}}, f"{k}.distribution unknown", f"population.{k}.distribution"),
    ]
    return rng.choice(options)


def _draws_nothing(rng: random.Random) -> tuple[dict, str, str]:
    options = [
        ({"sensors": {"draw": True}}, "sensor draw over an IMU without sensors", "population.sensors.draw"),
        ({"sensors": {"draw": True, "preset": "empty-preset.yaml"}}, "sensor draw over a preset without sigmas",
         "population.sensors.draw"),
        ({"sensors": {"draw": True, "preset": "missing.yaml"}}, "sensor preset file missing",
         "population.sensors.preset"),
        ({"temperature_k": {"width": 20}}, "temperature_k without its coefficient", "population.temperature_k"),
        ({"temperature_coefficient_ppm_per_k": {"mean": -30}}, "coefficient without temperature_k",
         "population.temperature_coefficient_ppm_per_k"),
        ({rng.choice(K_KEYS + ("f0_ppm",)): {}}, "a spread of mean 0 and width 0", "population."),
        ({"f0_ppm": {"distribution": "grid"}}, "a grid without values", "population.f0_ppm.values"),
    ]
    return rng.choice(options)


def _unknown_key(rng: random.Random) -> tuple[dict, str, str]:
    options = [
        ({"f0": {"width": 1}}, "population.f0 (no unit)", "population.f0"),
        ({"k3_percent": {"sigma": 5}}, "k3_percent.sigma (width is the key)", "population.k3_percent.sigma"),
        ({"sensors": {"draw": True, "preset": "preset.yaml", "scale": 2}}, "sensors.scale",
         "population.sensors.scale"),
        ({"gyro_bias_deg_h": {"width": 1}}, "a sensor key as a spread", "population.gyro_bias_deg_h"),
    ]
    return rng.choice(options)


def _make(rng: random.Random) -> Made:
    cls = rng.choice(CLASSES)
    scenario = _scenario(rng)
    doc = {"name": "fuzz-sweep", "seed": rng.randrange(2 ** 16), "units": 2,
           "scenarios": [{"path": "scenario.yaml", "duration_s": scenario["duration_s"]}]}
    if rng.random() < 0.3:  # two runs as one unit through two scenarios
        doc["units"] = 1
        doc["scenarios"].append({"path": "scenario.yaml", "duration_s": scenario["duration_s"] * 2, "label": "twice"})
    expect, key = "invalid", ""
    if cls == "population_valid":
        doc["population"], what = _valid_population(rng)
        expect = "valid"
    elif cls == "population_bad_value":
        doc["population"], what, key = _bad_value(rng)
    elif cls == "population_draws_nothing":
        doc["population"], what, key = _draws_nothing(rng)
    elif cls == "population_unknown_key":
        doc["population"], what, key = _unknown_key(rng)
    else:
        doc["population"] = {"f0_ppm": {"width": 1000}}
        text, expect = rng.choice([("1e3", "valid"), ("2.0e1", "valid"), ("1.5e0", "invalid"), ("-1e1", "invalid"),
                                   ("1e10", "invalid"), ("1e400", "invalid")])
        doc["seed"] = f"@@{text}@@"
        what = f"seed: {text}"
        key = "seed" if expect == "invalid" else ""
    body = yaml.safe_dump(doc, sort_keys=False)
    if cls == "population_seed_form":
        body = body.replace("'@@", "").replace("@@'", "")
    files = {"sweep.yaml": body.encode(), "scenario.yaml": yaml.safe_dump(scenario).encode(),
             "preset.yaml": yaml.safe_dump(PRESET).encode(), "empty-preset.yaml": yaml.safe_dump(PRESET_EMPTY).encode(),
             "expected-key.txt": key.encode()}
    return Made(cls, expect, f"sweep: {what}", files, "sweep.yaml")


def _validate(folder: Path) -> None:
    """The sweep checked as ``sins-sim sweep`` checks it before any task; a refusal must name the key the case
    broke (``expected-key.txt``), not only some key: else an AssertionError, which the harness counts as a
    traceback."""
    from sins_sim.config.errors import ConfigError
    from sins_sim.jobs.sweep.job import prepare_sweep

    key = (folder / "expected-key.txt").read_text()
    try:
        prepare_sweep(folder / "sweep.yaml")
    except ConfigError as exc:
        if key and f" {key}" not in str(exc):
            raise AssertionError(f"refused without naming {key}: {exc}") from None
        raise


FAMILY = Family(kind="sweep", weight=0.04, classes=CLASSES, make=_make,
                command=lambda folder: ["sweep", str(folder / "sweep.yaml"), "--out", str(folder / "out"),
                                        "--workers", "1", "--quiet"],
                validate=_validate)
