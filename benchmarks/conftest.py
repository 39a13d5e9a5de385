"""pytest-benchmark suite: per-sample cost of the kernels against same-run baselines.

Not collected by a plain ``pytest`` (``testpaths = ["tests"]``); run it explicitly::

    pytest benchmarks                      # full sizes (about a minute)
    pytest benchmarks --bench-quick        # CI: short inputs, few rounds (well under 2 minutes)

``SINS_BENCH_QUICK=1`` does the same as ``--bench-quick``. Every benchmark
makes one untimed call first, uses fixed inputs, checks its result against
an independent computation, and checks a same-run ratio against
``benchmarks/thresholds.json`` (``max``/``min`` enforced, ``target``
reported in ``extra_info``). The ratios use CPU-time medians
(``sins_sim.bench.timing.median_time``), robust on shared CI machines;
pytest-benchmark's own table records the kernels for ``--benchmark-compare``.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from sins_sim.bench import SIZES

THRESHOLDS_FILE = Path(__file__).with_name("thresholds.json")


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_auto_num_workers(config) -> int:
    """One process: pyproject's ``addopts`` runs the tests with ``-n auto`` (pytest-xdist), but the benchmarks
    compare CPU times measured in the same process, and pytest-benchmark turns itself off under xdist."""
    return 0


def pytest_addoption(parser):
    parser.addoption("--bench-quick", action="store_true", default=False,
                     help="sins_sim benchmarks: short inputs and few rounds (CI)")


@pytest.fixture(scope="session")
def quick(request) -> bool:
    """Quick mode: ``--bench-quick`` or ``SINS_BENCH_QUICK=1``."""
    return bool(request.config.getoption("--bench-quick")) or os.environ.get("SINS_BENCH_QUICK", "") not in ("", "0")


@pytest.fixture(scope="session")
def sizes(quick) -> dict:
    """Input sizes and repeats (``sins_sim.bench.SIZES``)."""
    return dict(SIZES[quick])


@pytest.fixture(scope="session")
def thresholds() -> dict:
    return json.loads(THRESHOLDS_FILE.read_text())


@pytest.fixture
def check_ratio(thresholds, benchmark):
    """``check_ratio(name, value)``: record the ratio and fail past its enforced threshold."""

    def check(name: str, value: float) -> None:
        rule = thresholds[name]
        benchmark.extra_info[name] = round(value, 4)
        if "target" in rule:
            benchmark.extra_info[name + " target"] = rule["target"]
        if "max" in rule:
            assert value <= rule["max"], f"{name} = {value:.3f} > {rule['max']} (benchmarks/thresholds.json)"
        if "min" in rule:
            assert value >= rule["min"], f"{name} = {value:.3f} < {rule['min']} (benchmarks/thresholds.json)"

    return check


@pytest.fixture
def record(benchmark, sizes):
    """``record(fn)``: pytest-benchmark's record of ``fn`` (one untimed warm-up round, then
    ``sizes["repeats"]`` rounds); returns ``fn``'s result."""

    def run(fn):
        return benchmark.pedantic(fn, rounds=sizes["repeats"], warmup_rounds=1, iterations=1)

    return run
