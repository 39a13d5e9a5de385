"""Command-line interface: thin argument parsing over the jobs layer.

Every command ends in one of four ways:

- success: exit status 0;
- bad input (an unphysical parameter, a malformed file, an unusable output
  path, a bad flag): one line ``sins-sim: error: <flag or field>: <rule>``
  on stderr, exit status 2;
- an internal failure (out of memory, a disk error, a bug): one line
  ``sins-sim: error: ...`` on stderr, exit status 1; ``SINS_SIM_DEBUG=1``
  re-raises it with the traceback;
- Ctrl-C or SIGTERM: ``sins-sim: interrupted``, exit status 130.

Never a traceback, and never a half-written result: outputs are written to a
temporary sibling and moved into place when the job has finished
(:mod:`sins_sim.jobs.output`). Never a silent loss: an existing result folder is
replaced only with ``--force``, and every result folder holds ``manifest.json``
(:mod:`sins_sim.jobs.manifest`; ``run --rerun DIR`` runs a ``run`` folder again). Python warnings raised by a job are printed as
one ``warning: <message>`` line each, once (:mod:`sins_sim.jobs.messages`),
also with ``--quiet`` (which silences only the progress bar).
"""

from __future__ import annotations

import argparse
import math
import os
import re
import signal
import sys
import threading
from contextlib import ExitStack, contextmanager

from sins_sim import __version__
from sins_sim.jobs.messages import capture_warnings, format_warning_lines
from sins_sim.config.errors import ConfigError

__all__ = ["main", "build_parser", "EXIT_OK", "EXIT_INTERNAL", "EXIT_USAGE", "EXIT_INTERRUPTED"]

EXIT_OK = 0
#: an internal failure (memory, disk, a bug)
EXIT_INTERNAL = 1
#: bad input: a parameter, a file, an output path, a flag
EXIT_USAGE = 2
#: Ctrl-C or SIGTERM (128 + SIGINT)
EXIT_INTERRUPTED = 130
#: set to 1 to get the traceback instead of the one-line message
DEBUG_ENV = "SINS_SIM_DEBUG"

#: ``channel``: internal field names in error messages -> the flag the user types (longest first)
CHANNEL_FLAGS = {
    "readout.anti_alias.cutoff_hz": "--anti-alias-hz",
    "readout.output_rate_hz": "--filter-rate",
    "readout.input_rate_hz": "--plant-rate",
    "readout.quantum_rad": "--quantum-arcsec",
    "readout.noise_rad": "--noise-arcsec",
    "drive.amplitude_rad": "--dither-arcmin",
    "drive.dac_rate_hz": "--plant-rate",
    "plant.rate_hz": "--plant-rate",
    "plant.hysteresis": "--hysteresis",
    "correcting.fs_hz": "--filter-rate",
    "correcting.f0_hz": "--f0",
    "suspension.f0_hz": "--f0",
    **{f"suspension.k{i}": f"--k{i}" for i in range(1, 6)},
    "output_rate_hz": "--filter-rate",
    "input_rate_hz": "--plant-rate",
    "settle_s": "--settle",
    "duration_s": "--duration",
    "f0_hz": "--f0",
    "motion_hz": "--motion-hz",
    "motion_arcmin": "--motion-arcmin",
    "drive.v_m": "--dither-arcmin",
    "drive.amplitude": "--dither-arcmin",
}


def _one_line(text) -> str:
    return " ".join(str(text).split())


def _name_flags(message: str, flags: dict | None) -> str:
    """Replace internal field names in ``message`` by the flags that set them."""
    if not flags:
        return message
    names = sorted(flags, key=len, reverse=True)
    pattern = re.compile(r"(?<![\w.])(" + "|".join(re.escape(n) for n in names) + r")(?![\w])")
    return pattern.sub(lambda m: flags[m.group(1)], message)


# --- argument types: checked before anything runs ------------------------------------------------
def _number(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be a finite number, got {text!r}")
    return value


def _positive(text: str) -> float:
    value = _number(text)
    if not value > 0.0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text!r}")
    return value


def _non_negative(text: str) -> float:
    value = _number(text)
    if not value >= 0.0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {text!r}")
    return value


def _seed(text: str) -> int:
    """A seed as a file takes it: an integer in [0, 2^32 - 1], also written as a whole number in exponent form
    (``--seed 1e3`` like ``seed: 1e3`` in a scenario or sweep file)."""
    try:
        value = int(text)
    except ValueError:
        try:
            num = float(text)
        except ValueError:
            num = math.nan
        if not (math.isfinite(num) and num.is_integer()):
            raise argparse.ArgumentTypeError(f"must be an integer >= 0, got {text!r}") from None
        value = int(num)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be an integer >= 0, got {text!r}")
    if value > 2 ** 32 - 1:
        raise argparse.ArgumentTypeError(f"must be at most 2^32 - 1 = {2 ** 32 - 1}, got {text!r}")
    return value


def _count(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be an integer >= 1, got {text!r}")
    return value


class _Parser(argparse.ArgumentParser):
    """argparse with the package's one-line error format."""

    def error(self, message):
        self.exit(EXIT_USAGE, f"sins-sim: error: {_one_line(message)} (see: {self.prog} --help)\n")


# --- progress --------------------------------------------------------------------------------------
class _Progress:
    """A tqdm bar on stderr behind the jobs' ``progress(fraction)`` callback (rate and time left shown).

    A job that estimates its run (:mod:`sins_sim.jobs.estimate`) calls :meth:`estimate` before the engine
    starts, with the estimate calibrated on this machine. When numba's cache is cold a first bar,
    "compiling (first run only)", counts the wall seconds against the compile estimate until the first
    progress report; then the run's bar counts simulated seconds (rate in ``s/s``) and shows the time left
    measured on the run itself (:class:`sins_sim.jobs.estimate.RemainingTime`: "estimating" until a few chunks
    have run, never a countdown from the model). Without an estimate the bar counts percent. When the run
    finishes, its timing calibrates the next estimate (:func:`sins_sim.jobs.estimate.record_timing`).
    """

    def __init__(self, label: str, disable: bool):
        self.label = label
        self.disable = disable
        self.bar = None  # made when the job reports its estimate or its first progress: no bar before an error
        self.est = None
        self._compile = None  # (bar, stop event, thread) while the kernels compile
        self._times = {}
        self.printed = set()  # warnings already printed by advise(), not repeated at the end
        self.left = None  # the time left, measured as the run goes (made with the estimate or the first report)

    def _open(self, total: float, unit: str, postfix: str = "", initial: float = 0.0):
        from tqdm import tqdm

        self.bar = tqdm(total=total, desc=self.label, unit=unit, file=sys.stderr, disable=self.disable, leave=True,
                        dynamic_ncols=True, postfix=postfix or None, initial=initial,
                        bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.4g}/{total:.4g} {unit} "
                                   "[{elapsed}, {rate_fmt}{postfix}]")  # the time left: self.left, measured

    def _run_postfix(self) -> str:
        return self._left().text()

    def _left(self):
        """The run's time left, from its own measured throughput (:class:`sins_sim.jobs.estimate.RemainingTime`)."""
        if self.left is None:
            from sins_sim.jobs.estimate import RemainingTime

            self.left = RemainingTime(self.est)
        return self.left

    def estimate(self, est: dict) -> None:
        """Show the compile phase (cold cache) or the run's bar (called by the job before the engine starts)."""
        import time

        from sins_sim.jobs.estimate import format_duration

        if self.bar is not None or self._compile is not None or not float(est["simulated_s"]) > 0.0:
            return
        self.est = est
        self._times["start"] = time.perf_counter()
        compile_s = float(est.get("compile_s", 0.0))
        if compile_s <= 0.0:
            self._open(float(est["simulated_s"]), "s", self._run_postfix())
            return
        from tqdm import tqdm

        bar = tqdm(total=compile_s, desc=f"{self.label}: compiling (first run only)", unit="s", file=sys.stderr,
                   disable=self.disable, leave=True, dynamic_ncols=True,
                   postfix=f"estimate {format_duration(compile_s)}",
                   bar_format="{desc}: {percentage:3.0f}%|{bar}| [{elapsed}<{remaining}{postfix}]")
        stop = threading.Event()
        t0 = self._times["start"]

        def tick():  # the wall clock against the estimate, held below 100 % until the kernels are ready
            while not stop.wait(0.5):
                target = min(time.perf_counter() - t0, 0.99 * bar.total)
                if target > bar.n:
                    bar.update(target - bar.n)

        thread = threading.Thread(target=tick, name="sins-sim-compile-progress", daemon=True)
        thread.start()
        self._compile = (bar, stop, thread)

    def _end_compile(self) -> None:
        if self._compile is None:
            return
        bar, stop, thread = self._compile
        self._compile = None
        stop.set()
        thread.join()
        bar.total = bar.n if bar.n > 0 else bar.total  # done: the bar shows the time it took
        bar.set_postfix_str("done", refresh=False)
        bar.close()

    def __call__(self, fraction: float) -> None:
        import time

        now = time.perf_counter()
        fraction = min(max(float(fraction), 0.0), 1.0)
        if "first" not in self._times:
            self._times["first"] = (now, fraction)
        self._times["last"] = (now, fraction)
        self._left().update(fraction)
        if self.bar is None:
            if self._compile is not None:
                self._end_compile()
                total = float(self.est["simulated_s"])
                self._open(total, "s", self._run_postfix(), initial=total * fraction)  # rate from here on
            else:
                self._open(100.0, "%")
        self.bar.set_postfix_str(self._left().text(), refresh=False)
        done = self.bar.total * fraction
        if done > self.bar.n:
            self.bar.update(done - self.bar.n)

    def phase(self, text: str) -> None:
        """Say what the job does after the engine (no more simulated seconds to count): replaces the time left."""
        if self.bar is not None:
            self.bar.set_postfix_str(text, refresh=True)

    def advise(self, message: str) -> None:
        """Print a job's configuration-time warning now, one line (before the engine runs), and remember it."""
        from sins_sim.jobs.messages import format_warning_lines

        for line in format_warning_lines([message]):
            if self.bar is not None:
                self.bar.write(line, file=sys.stderr)
            else:
                sys.stderr.write(line + "\n")
                sys.stderr.flush()
        self.printed.add(message)

    def close(self, record: bool = True) -> None:
        """Close the bars; ``record``: the job succeeded, so its timing calibrates the next estimate."""
        self._end_compile()
        if self.bar is not None:
            self.bar.close()
        if record and self.est is not None and "first" in self._times:
            from sins_sim.jobs.estimate import record_timing

            import time

            (t1, f1), (t2, f2) = self._times["first"], self._times["last"]
            record_timing(self.est, self._times["start"], t1, f1, t2, f2, t_end=time.perf_counter())


@contextmanager
def _progress(label: str, quiet: bool):
    bar = _Progress(label, disable=quiet)
    ok = False
    try:
        yield bar
        ok = True
    finally:
        bar.close(record=ok)


# --- result folders: refused when they exist (unless --force), each with its manifest.json -----------------
#: parsed-argument names that are not the command's settings
_NOT_SETTINGS = ("func", "flags", "job_warnings", "argv")


def _manifest(args):
    """The command's :class:`~sins_sim.jobs.manifest.Manifest`: command line and parsed flags."""
    from sins_sim.jobs.manifest import Manifest

    settings = {k: v for k, v in vars(args).items() if k not in _NOT_SETTINGS}
    return Manifest(args.command, getattr(args, "argv", None), settings=settings)


def _result_dir(args, path, flag: str = "--out", inputs=(), manifest=None):
    """The atomic result folder of a command (refused when it exists, unless ``--force``), with its manifest."""
    from sins_sim.jobs.manifest import result_dir

    return result_dir(path, manifest if manifest is not None else _manifest(args), flag, inputs=inputs,
                      force=getattr(args, "force", False))


# --- commands -------------------------------------------------------------------------------------
def _cmd_channel(args) -> int:
    from sins_sim.models.drive import DriveParams
    from sins_sim.models.plant import PlantSettings
    from sins_sim.models.readout import AntiAliasParams, ReadoutParams
    from sins_sim.models.suspension import SuspensionParams
    from sins_sim.jobs.channel import default_settle_s, make_motion, run_channel_job
    from sins_sim.simulation.channel import ChannelConfig
    from sins_sim.units import ARCMIN, ARCSEC

    suspension = SuspensionParams(f0_hz=args.f0, k1=args.k1, k2=args.k2, k3=args.k3, k4=args.k4, k5=args.k5)
    readout = ReadoutParams(
        quantum_rad=args.quantum_arcsec * ARCSEC,
        noise_rad=args.noise_arcsec * ARCSEC,
        input_rate_hz=args.plant_rate,
        output_rate_hz=args.filter_rate,
        anti_alias=None if args.anti_alias == "off" else AntiAliasParams(cutoff_hz=args.anti_alias_hz),
    )
    config = ChannelConfig(
        suspension=suspension,
        drive=DriveParams(amplitude_rad=args.dither_arcmin * ARCMIN, dac_rate_hz=args.plant_rate),
        plant=PlantSettings(rate_hz=args.plant_rate, hysteresis=args.hysteresis),
        readout=readout,
        filter_hysteresis=args.hysteresis,
    )
    motion = make_motion(args.motion, args.motion_hz, args.motion_arcmin)
    settle = default_settle_s(args.duration) if args.settle is None else args.settle
    if not settle < args.duration:
        raise ConfigError(f"--settle: must be < --duration = {args.duration:g} s, got {settle:g}")
    with _result_dir(args, args.out) as tmp, _progress("channel", args.quiet) as progress:
        metrics = run_channel_job(config, args.duration, motion, tmp, settle_s=settle, seed=args.seed,
                                  progress=progress)
    rms = metrics["residual_rms_arcsec"]
    print(f"drive {metrics['drive']['frequency_hz']:.3f} Hz, {metrics['drive']['v_m']:.4g} V; "
          f"Q = {metrics['suspension']['q_at_amplitude']:.1f}")
    print("residual RMS vs true SINS angle (arcsec): " + ", ".join(f"{k} {val:.4g}" for k, val in rms.items()))
    print(f"wrote {args.out}/channel.png, metrics.json, timeseries.npz")
    return EXIT_OK


def _cmd_run(args) -> int:
    from pathlib import Path

    from sins_sim.jobs.run import run_scenario

    overrides = _overrides(args)
    out = Path(args.out)
    rerun = None
    if args.rerun is not None:
        rerun = _rerun_source(args, overrides, out)
        args.scenario = str(rerun[0])
    elif args.scenario is None:
        raise ConfigError("scenario: name a scenario file, or --rerun DIR to run a result folder again")
    manifest = _manifest(args)
    if rerun is not None:
        manifest.doc["rerun_of"] = {"folder": str(Path(args.rerun).resolve()),
                                    "started_utc": rerun[1].get("started_utc"),
                                    "sins_sim_version": rerun[1].get("sins_sim_version")}
    with _result_dir(args, out, inputs=[args.scenario], manifest=manifest) as tmp, \
            _progress(Path(args.scenario).stem if rerun is None else f"rerun {Path(args.rerun).name}",
                      args.quiet) as progress:
        metrics = run_scenario(args.scenario, tmp, progress=progress, overrides=overrides, manifest=manifest)
    print(f"navigation error against truth after {metrics['duration_s']:g} s "
          f"(navigation from {metrics['navigation']['start_s']:g} s):")
    print(f"{'filter':<18}{'horizontal m':>14}{'max m':>11}{'vertical m':>12}{'velocity m/s':>14}"
          f"{'phi RMS N,E,D arcsec':>30}  status")
    for name, m in metrics["filters"].items():
        if "horizontal_position_error_m" not in m:
            print(f"{name:<18}{'':>81}  {m['status']}")
            continue
        rms = ", ".join(f"{x:.3g}" for x in m["attitude_error_arcsec"]["rms"].values())
        print(f"{name:<18}{m['horizontal_position_error_m']['final']:>14.4g}{m['horizontal_position_error_m']['max']:>11.4g}"
              f"{m['vertical_position_error_m']['final']:>12.3g}{m['velocity_error_m_s']['final']:>14.3g}{rms:>30}  "
              f"{m['status']}")
    aligned = [(n, m["alignment"]) for n, m in metrics["filters"].items() if "alignment" in m]
    if aligned:
        print(f"alignment ({aligned[0][1]['method']}, {aligned[0][1]['duration_s']:g} s) against the true attitude:")
        for name, a in aligned:
            print(f"{name:<18}heading error {a['error_heading_deg']:+.4g} deg (sigma {a['sigma_heading_deg']:.3g}), "
                  f"tilt N, E {a['error_tilt_north_arcsec']:+.3g}, {a['error_tilt_east_arcsec']:+.3g} arcsec")
    for name, d in metrics.get("diverged", {}).items():
        print(f"diverged: {name}, axis {d['axis']}, t = {d['time_s']:.4g} s: {d['reason']}")
    args.job_warnings.extend(w for w in metrics.get("warnings", []) if w not in progress.printed)
    if rerun is not None:
        _compare_rerun(args, rerun[1], out)
    print(f"report: {out / 'report.md'}")
    return EXIT_OK


def _rerun_source(args, overrides: dict, out):
    """``run --rerun DIR``: the checked ``DIR/inputs/scenario.yaml`` and DIR's manifest."""
    import os

    from sins_sim.jobs.manifest import rerun_scenario

    if args.scenario is not None:
        raise ConfigError(f"--rerun: runs {args.rerun} as it was run; give no scenario file (got {args.scenario})")
    if overrides:
        flags = {"seed": "--seed", "duration_s": "--duration", "imu": "--imu", "filter_parameters": "--filter-parameters"}
        raise ConfigError(f"--rerun: reproduces {args.rerun} as it was run; {flags[next(iter(overrides))]} would "
                          f"change it (run {os.path.join(args.rerun, 'inputs', 'scenario.yaml')} with it instead)")
    if os.path.exists(out) and os.path.exists(args.rerun) and os.path.samefile(out, args.rerun):
        raise ConfigError(f"--out: {out} is the folder being rerun; the rerun goes into a new folder, so that "
                          "the two can be compared")
    return rerun_scenario(args.rerun, "--rerun")


def _compare_rerun(args, old: dict, out) -> None:
    """Say whether the rerun's metrics.json equals the original's (the manifest holds both hashes)."""
    from sins_sim.jobs.manifest import sha256_file

    before = (old.get("outputs") or {}).get("metrics.json")
    if before is None:
        args.job_warnings.append(f"--rerun: {args.rerun}'s manifest has no hash of metrics.json: nothing to "
                                 "compare with")
    elif sha256_file(out / "metrics.json") == before:
        print(f"rerun: metrics.json is identical to {args.rerun}'s (SHA-256 {before[:12]}...)")
    else:
        args.job_warnings.append(f"--rerun: metrics.json differs from {args.rerun}'s (SHA-256 of the original "
                                 f"{before[:12]}...): compare the two folders")


def _cmd_budget(args) -> int:
    from pathlib import Path

    from sins_sim.jobs.budget import run_budget
    from sins_sim.jobs.manifest import record_scenario

    from tqdm import tqdm

    out = Path(args.out)
    bar = None

    def progress(done, total):
        nonlocal bar
        if bar is None:
            bar = tqdm(total=total, desc=f"{Path(args.scenario).stem} budget", unit="run", file=sys.stderr,
                       disable=args.quiet, dynamic_ncols=True)
        bar.update(done - bar.n)

    manifest = _manifest(args)
    try:
        with _result_dir(args, out, inputs=[args.scenario], manifest=manifest) as tmp:
            b = run_budget(args.scenario, tmp, overrides=_overrides(args), workers=args.workers, progress=progress)
            record_scenario(manifest, args.scenario, _overrides(args))  # validated by the budget's first load
    finally:
        if bar is not None:
            bar.close()
    filters = [f for f in b["filters"] if b["total"].get(f)]
    print(f"error budget after {b['duration_s']:g} s ({b['runs']} runs): final horizontal position error (m)")
    print(f"{'source':<34}" + "".join(f"{f:>18}" for f in filters))

    def line(label, d):
        vals = [(d.get(f) or {}).get("horizontal_position_error_m") for f in filters]
        print(f"{label:<34}" + "".join(f"{v:>18.4g}" if v is not None else f"{'n/a':>18}" for v in vals))

    line("total", b["total"])
    for src, d in b["sources"].items():
        line(src, d)
    line("floor (no source)", b["floor"])
    line("remainder", b["remainder"])
    print(f"report: {out / 'report.md'}")
    return EXIT_OK


def _cmd_reproduce(args) -> int:
    from pathlib import Path

    from sins_sim.jobs.reproduce import run_reproduce

    out = Path(args.out)
    with _result_dir(args, out) as tmp, _progress("reproduce", args.quiet) as progress:
        run_reproduce(tmp, quick=args.quick, progress=progress)
    print(f"report: {out / 'report.md'}; numbers: {out / 'numbers.json'}")
    return EXIT_OK


def _cmd_compare_filters(args) -> int:
    from pathlib import Path

    from sins_sim.jobs.compare_filters import run_compare_filters
    from sins_sim.jobs.output import check_out_file

    from sins_sim.jobs.compare_filters import resolve_unit

    if args.json is not None:
        check_out_file(args.json, "--json")  # before minutes of computation (it was found only at the end)
    resolve_unit(args.imu, args.scenario)  # a bad --imu or --scenario: one line, before the result folder
    out = Path(args.out)
    inputs = tuple(x for x in (args.imu, args.scenario) if x is not None)
    with _result_dir(args, out, inputs=inputs) as tmp, _progress("compare-filters", args.quiet) as progress:
        res = run_compare_filters(tmp, Path(tmp) / "filters.json", quick=args.quick, progress=progress,
                                  imu=args.imu, scenario=args.scenario)
    numbers = out / "filters.json"
    if args.json is not None:  # a copy where the user asked for it too
        from sins_sim.jobs.output import atomic_write_text

        atomic_write_text(args.json, numbers.read_text())
        numbers = args.json
    print(f"best: {res['best']}; report: {out / 'report.md'}; numbers: {numbers}")
    return EXIT_OK


def _cmd_bench(args) -> int:
    import json

    from sins_sim.bench import format_table, run_bench
    from sins_sim.jobs.output import atomic_write_text, check_out_file

    target = check_out_file(args.json, "--json") if args.json is not None else None
    result = run_bench(quick=args.quick)
    print(format_table(result))
    if target is not None:
        atomic_write_text(target, json.dumps(result, indent=2) + "\n")
        print(f"wrote {args.json}")
    return EXIT_OK


def _cmd_simulate_recording(args) -> int:
    from sins_sim.jobs.output import atomic_output_file
    from sins_sim.jobs.recording_jobs import simulate_recording

    with atomic_output_file(args.out, "--out") as tmp:
        info = simulate_recording(args.spec, tmp)
    print(f"wrote {args.out}: axes {', '.join(info['axes'])}, {info['n_samples']} samples at {info['fs_hz']:g} Hz "
          f"({info['duration_s']:g} s)")
    return EXIT_OK


def _cmd_import_csv(args) -> int:
    from sins_sim.jobs.output import atomic_output_file
    from sins_sim.jobs.recording_jobs import import_csv

    with atomic_output_file(args.out, "--out") as tmp:
        info = import_csv(args.csv, tmp, quantum_arcsec=args.quantum_arcsec, nominal=args.nominal,
                          experiment=args.experiment, initial_state=args.initial_state,
                          description=args.description, fs_hz=args.fs_hz)
    print(f"wrote {args.out}: axes {', '.join(info['axes'])}, {info['n_samples']} samples at "
          f"{info['fs_hz']:g} Hz ({info['duration_s']:g} s)")
    return EXIT_OK


def _cmd_diagnose(args) -> int:
    from sins_sim.jobs.output import atomic_output_file
    from sins_sim.jobs.recording_jobs import diagnose, diagnose_many, format_diagnosis

    effects = [e.strip() for e in args.effects.split(",") if e.strip()] if args.effects else None
    if args.json is not None and args.report is not None:
        report, js = os.path.abspath(args.report), os.path.abspath(args.json)
        if os.path.commonpath([report, js]) == report:
            # the report folder is replaced as a whole when the run succeeds: the JSON would go with it
            raise ConfigError(f"--json: must not be inside --report {args.report} (the folder is replaced as a "
                              "whole); write it beside the folder")
    if len(args.recording) > 1 and args.suggest is not None:
        raise ConfigError("--suggest: names one experiment file, so it takes one recording (got "
                          f"{len(args.recording)})")
    if len(args.recording) > 1:  # several: --json and --report name folders, one entry per recording
        progress = lambda line: print(line, file=sys.stderr, flush=True)  # noqa: E731
        with ExitStack() as stack:
            json_tmp = (stack.enter_context(_result_dir(args, args.json, "--json", inputs=args.recording))
                        if args.json is not None else None)
            report_tmp = (stack.enter_context(_result_dir(args, args.report, "--report", inputs=args.recording))
                          if args.report is not None else None)
            results = diagnose_many(args.recording, json_dir=json_tmp, report_dir=report_tmp, effects=effects,
                                    jobs=args.jobs, progress=progress)
        for path, result in zip(args.recording, results):
            print(f"== {path}")
            print(format_diagnosis(result))
        return EXIT_OK
    with ExitStack() as stack:
        json_tmp = stack.enter_context(atomic_output_file(args.json, "--json")) if args.json is not None else None
        report_tmp = (stack.enter_context(_result_dir(args, args.report, "--report", inputs=args.recording))
                      if args.report is not None else None)
        suggest_tmp = (stack.enter_context(atomic_output_file(args.suggest, "--suggest"))
                       if args.suggest is not None else None)
        result = diagnose(args.recording[0], json_out=json_tmp, report_dir=report_tmp, effects=effects,
                          suggest_out=suggest_tmp)
    print(format_diagnosis(result))
    if args.suggest is not None:
        print(f"wrote {args.suggest}: the experiment that separates the close call"
              if result["verdict"].get("close_call") else
              f"no close call: nothing to separate, {args.suggest} not written")
    return EXIT_OK


def _seed_list(text: str) -> list:
    """``--seeds``: comma-separated integers >= 0 (one ConfigError line otherwise)."""
    try:
        seeds = [int(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise ConfigError(f"--seeds: must be comma-separated integers, got {text!r}") from None
    if not seeds or any(x < 0 for x in seeds):
        raise ConfigError(f"--seeds: must be comma-separated integers >= 0, got {text!r}")
    return seeds


def _cmd_diagnose_eval(args) -> int:
    from sins_sim.jobs.output import atomic_output_file
    from sins_sim.jobs.recording_jobs import diagnose_eval, format_eval

    progress = None if args.quiet else (lambda line: print(line, file=sys.stderr, flush=True))
    seeds = None
    if args.holdout:
        from sins_sim.identification.blind_hard import HOLDOUT_SEEDS

        if not args.hard or args.seeds is not None:
            raise ConfigError("--holdout: runs the hard set's unlooked-at seeds: give it with --hard and without "
                              "--seeds")
        seeds = list(HOLDOUT_SEEDS)
    elif args.seeds is not None:
        seeds = _seed_list(args.seeds)
    labels = None
    if args.labels is not None:
        labels = [x.strip() for x in args.labels.split(",") if x.strip()]
        if not labels:
            raise ConfigError(f"--labels: must be comma-separated class names, got {args.labels!r}")
    with ExitStack() as stack:
        json_tmp = stack.enter_context(atomic_output_file(args.json, "--json")) if args.json is not None else None
        result = diagnose_eval(args.n, args.seed, duration_s=args.duration, json_out=json_tmp, progress=progress,
                               jobs=args.jobs, suite="hard" if args.hard else "standard", seeds=seeds,
                               labels=labels)
    print(format_eval(result))
    return EXIT_OK


def _cmd_identify_eval(args) -> int:
    import json
    from pathlib import Path

    from sins_sim.jobs.identify_eval import format_identify_eval, identify_eval
    from sins_sim.jobs.output import atomic_output_file

    seeds = _seed_list(args.seeds)
    if args.twin_seeds < 2:
        raise ConfigError(f"--twin-seeds: must be at least 2 (an envelope), got {args.twin_seeds}")
    progress = None if args.quiet else (lambda line: print(line, file=sys.stderr, flush=True))
    try:
        classes = [c.strip() for c in args.classes.split(",") if c.strip()] if args.classes else None
        result = identify_eval(seeds, holdout=args.holdout, minutes=args.minutes, twin_seeds=args.twin_seeds,
                               classes=classes, progress=progress)
    except ValueError as exc:
        raise ConfigError(f"identify-eval: {exc}") from None
    if args.json is not None:
        with atomic_output_file(args.json, "--json") as tmp:
            Path(tmp).write_text(json.dumps(result, indent=2, default=str) + "\n")
    print(format_identify_eval(result))
    return EXIT_OK


class _TaskBar:
    """A tqdm bar over a sweep's runs on stderr: it moves per finished run and shows the rate and the time left.

    Before the first run finishes the bar says what is happening (``phase``: the cluster starting, the
    first runs compiling). The rate (runs/min) counts the runs after the first over the time since the first
    finished: the first run carries the cluster's start-up and the workers' compilation (minutes on a busy
    machine), which the others do not, so a mean from the start would predict hours for a sweep that ends in
    seconds. The time left is the runs left over that rate. On a terminal a clock thread redraws the bar every
    second, so the elapsed time and the rate move between finished runs.
    """

    def __init__(self, label: str, disable: bool):
        self.label, self.disable, self.bar = label, disable, None
        self.text, self.failed, self.t_first = "", 0, None
        self._stop = threading.Event()
        self._clock = None

    def _postfix(self) -> str:
        import time

        from sins_sim.jobs.estimate import format_duration

        done, total = self.bar.n, self.bar.total
        parts = []
        since = time.monotonic() - self.t_first if self.t_first is not None else 0.0
        if done >= 2 and (since >= 1.0 or done >= total):  # not from a few ms between two workers' first runs
            rate = (done - 1) / max(since, 1e-3)  # runs/s after the first (class docstring)
            parts.append(f"{60.0 * rate:.3g} runs/min")
            if done < total:
                parts.append(f"about {format_duration((total - done) / rate)} left")
        elif done and done < total:
            parts.append(f"first run finished after {format_duration(self.bar.format_dict['elapsed'])}; "
                         "measuring the rate")
        elif not done and self.text:
            parts.append(self.text)
        if self.failed:
            parts.append(f"{self.failed} failed")
        return ", ".join(parts)

    def _refresh(self) -> None:
        if self.bar:
            self.bar.set_postfix_str(self._postfix(), refresh=True)

    def _tick(self) -> None:
        while not self._stop.wait(1.0):
            self._refresh()

    def phase(self, text: str) -> None:
        """What happens before the first run finishes (shown until then)."""
        self.text = text
        self._refresh()

    def __call__(self, done: int, total: int, failed: int) -> None:
        if self.bar is False:
            return
        if self.bar is None:
            from tqdm import tqdm

            self.bar = tqdm(total=total, desc=self.label, file=sys.stderr, disable=self.disable, dynamic_ncols=True,
                            bar_format="{desc}: {n_fmt}/{total_fmt} runs |{bar}| {elapsed}{postfix}")
            if not self.disable and sys.stderr.isatty():
                self._clock = threading.Thread(target=self._tick, name="sweep-progress-clock", daemon=True)
                self._clock.start()
        if done and self.t_first is None:
            import time

            self.t_first = time.monotonic()
        self.failed = failed
        self.bar.update(done - self.bar.n)
        self._refresh()
        if done >= total:
            self.close()

    def close(self) -> None:
        self._stop.set()
        if self._clock is not None:
            self._clock.join()
            self._clock = None
        if self.bar:
            self.bar.close()
            self.bar = False  # closed: no second bar


def _quantile_cell(q: dict) -> str:
    """``1.23 [1.01, 1.50]``: a supported quantile and its bootstrap 95 % interval."""
    lo, hi = q["ci95"]
    return f"{q['value']:.3g} [{lo:.3g}, {hi:.3g}]"


def _print_percentiles(summary: dict, metric: str) -> None:
    """Per scenario and filter: each quantile that the sample supports with its interval, and n; one line on
    each quantile left out."""
    rows = [(label, f, q) for label, block in summary["by_scenario"].items()
            for f, q in block["percentiles"].get(metric, {}).items()]
    keys = [k for k in ("p50", "p95", "p99") if any(q[k]["supported"] for _, _, q in rows)]
    width = max([len(_quantile_cell(q[k])) for _, _, q in rows for k in keys if q[k]["supported"]] + [11]) + 2
    print(f"{'scenario':<22}{'filter':<18}" + "".join(f"{k + ' [95% CI]':>{width}}" for k in keys) + f"{'n':>6}")
    for label, f, q in rows:
        cells = "".join(f"{_quantile_cell(q[k]) if q[k]['supported'] else '-':>{width}}" for k in keys)
        print(f"{label:<22}{f:<18}{cells}{q['n']:>6}")
    for k in ("p50", "p95", "p99"):
        short = sorted({q["n"] for _, _, q in rows if not q[k]["supported"]})
        if short:
            need = next(q[k]["n_required"] for _, _, q in rows if not q[k]["supported"])
            print(f"{k} not shown where n < {need} (n = {', '.join(map(str, short))} here): fewer values cannot "
                  f"bracket the {k[1:]}th percentile in a 95 % interval (distribution-free, order statistics)")


def _print_drivers(summary: dict, metric: str) -> None:
    """The significant drivers of ``metric`` per scenario and filter, or that there is none at that n."""
    m = summary["methods"]["drivers"]
    blocks = {label: d[metric] for label, d in summary["drivers"].items() if metric in d}
    if not blocks:
        return
    print(f"drivers (Spearman rho; p adjusted over all {m['tests']} driver tests, Westfall-Young maxT, "
          f"family-wise error {m['alpha']:g}):")
    floor = 1.0 / (1.0 + m["permutations"])  # the smallest p-value the permutations give: "at most"

    def p_text(name, p):
        return f"{name} <= {floor:.2g}" if p <= floor else f"{name} {p:.2g}"

    for label, per in blocks.items():
        quiet: dict = {}
        for f, d in per.items():
            if d["significant"]:
                shown = "; ".join(f"{r['parameter']} rho {r['spearman']:+.2f}, {p_text('p', r['p'])}, "
                                  f"{p_text('p_adj', r['p_adjusted'])}, n {r['n']}" for r in d["significant"][:3])
                more = f" (+{len(d['significant']) - 3} in summary.json)" if len(d["significant"]) > 3 else ""
                print(f"  {label:<20}{f:<18}{shown}{more}")
            else:
                quiet.setdefault(d["n"], []).append(f)
        for n, fs in quiet.items():
            print(f"  {label:<20}no significant driver at n = {n} ({', '.join(fs)})")


def _cmd_sweep(args) -> int:
    from pathlib import Path

    from sins_sim.jobs.sweep import run_sweep

    if args.rerun is not None:
        return _rerun_sweep(args)
    if args.out is None:
        raise ConfigError("--out: name the sweep folder (required, except with --rerun)")
    bar = _TaskBar(Path(args.sweep).stem, args.quiet)
    try:
        res = run_sweep(args.sweep, args.out, scheduler=args.scheduler, workers=args.workers, progress=bar,
                        phase=bar.phase, log=lambda line: print(line, flush=True), force=args.force,
                        manifest=_manifest(args), batch=args.batch_size)
    finally:
        bar.close()
    s = res["summary"]
    if res["computed"] + res["failed"]:
        print(f"ran {res['computed'] + res['failed']} runs in {res['wall_s']:.1f} s "
              f"({60.0 * res['runs_per_s']:.3g} runs/min)" + (f", {res['failed']} failed" if res["failed"] else ""))
    else:
        print("all runs were already done")
    metric = "horizontal_position_error_m_final"
    print(f"{s['runs']} runs in the table, {s['failed']} failed; final horizontal position error (m) over the units "
          f"(95 % CI: percentile bootstrap):")
    _print_percentiles(s, metric)
    _print_drivers(s, metric)
    if res["warned_runs"]:
        args.job_warnings.append(f"{res['warned_runs']} run(s) warned: see the warnings column of "
                                 f"{Path(args.out) / 'runs.parquet'}")
    print(f"wrote {args.out}: runs.parquet, summary.json, {len(res['files']) - 2} figure(s)")
    return EXIT_OK


def _rerun_sweep(args) -> int:
    """``sins-sim sweep SWEEP --rerun RUN_ID [--out DIR]``: one run alone, compared with DIR's stored row."""
    from sins_sim.jobs.sweep.job import rerun
    from sins_sim.jobs.sweep.tasks import HEADLINE_METRICS, METRICS

    res = rerun(args.sweep, args.rerun, args.out)
    t, row = res["task"], res["row"]
    print(f"unit {t.unit}, {t.scenario} (key {t.key}, seed {t.seed}): ran alone in {res['wall_s']:.2f} s")
    filters = sorted({c.split(".")[0] for c in row if c.endswith(".status")})
    for f in filters:
        vals = [f"{METRICS[m]} {row[f'{f}.{m}']:.6g}" for m in HEADLINE_METRICS
                if isinstance(row.get(f"{f}.{m}"), float) and row[f"{f}.{m}"] == row[f"{f}.{m}"]]
        print(f"  {f} ({row[f'{f}.status']}): " + "; ".join(vals))
    if row.get("warnings"):
        args.job_warnings.extend(row["warnings"].splitlines())
    if res["stored"] is None:
        if args.out is not None:
            print(f"no stored row of this run in {args.out} to compare with")
        return EXIT_OK
    if res["differs"]:
        print(f"differs from {res['stored']} in {len(res['differs'])} column(s): {', '.join(res['differs'][:10])}"
              + (" ..." if len(res["differs"]) > 10 else ""))
        return EXIT_INTERNAL
    print(f"identical to {res['stored']} (every column but wall_s and worker, compared exactly)")
    return EXIT_OK


def _cmd_lockin_study(args) -> int:
    from sins_sim.jobs.lockin_study import lockin_study
    from sins_sim.jobs.output import check_out_dir

    check_out_dir(args.out, "--out", force=args.force)  # before minutes of computation
    res = lockin_study(args.out, quick=args.quick, seed=args.seed, force=args.force, manifest=_manifest(args))
    print(f"ARW vs lock-in rate: log-log slope {res['slope_vs_lockin']:.3f} (analytic 1)")
    print(f"wrote {args.out}: lockin.json, arw_vs_lockin.png, dynamic_lockin.png, report.md")
    return EXIT_OK


def _cmd_separation_study(args) -> int:
    from sins_sim.config.imu import load_imu
    from sins_sim.jobs.output import check_out_dir
    from sins_sim.jobs.separation_study import DEFAULT_SEPARATIONS_HZ, separation_study

    from sins_sim.simulation.drive_pll import PllSettings

    check_out_dir(args.out, "--out", force=args.force)  # before minutes of computation
    try:
        pll = PllSettings(bandwidth_hz=args.pll_bandwidth_hz)
    except ValueError as exc:
        raise ConfigError(f"--pll-bandwidth-hz: {str(exc).split(': ', 1)[-1]}") from None
    imu = load_imu(args.imu)
    scenario = None
    if args.scenario is not None:
        from sins_sim.config.scenario import load_scenario

        scenario = load_scenario(args.scenario)
    pair = tuple(p.strip() for p in args.pair.split(","))
    seps = args.separations_hz if args.separations_hz else DEFAULT_SEPARATIONS_HZ
    inputs = (args.imu,) + ((args.scenario,) if args.scenario is not None else ())
    with _progress("separation-study", False) as progress:
        res = separation_study(imu, args.out, pair=pair, separations_hz=seps, duration_s=args.duration_s,
                               start_s=args.start_s, axis_offset_mrad=args.axis_offset_mrad,
                               budget_arcsec=args.budget_arcsec, seed=args.seed, scenario=scenario, pll=pll,
                               force=args.force, manifest=_manifest(args), inputs=inputs, progress=progress)
    ans = res["answer"]
    print(f"separation above which the dither coning's beat in the heading error stays within {ans['budget_arcsec']:g} "
          "arcsec: "
          + ", ".join(f"{n} " + ("> the largest tested" if v is None else f"{v:g} Hz")
                      for n, v in ans["required_separation_hz"].items()))
    lock = ans["no_entrainment_risk_down_to_hz"]
    print("no entrainment risk down to " + ("no tested separation" if lock is None else f"{lock:g} Hz"))
    print(f"wrote {args.out}: separation.json, separation.csv, intermodulation.csv, pll_vibration.csv, separation.png, report.md")
    return EXIT_OK


def _cmd_online_study(args) -> int:
    from pathlib import Path

    from sins_sim.jobs.online_study import crosscheck, online_study, print_crosscheck, study_filters

    if args.crosscheck:
        if args.scenario or args.out:
            raise ConfigError("--crosscheck: takes a recording and a diagnosis only, not a scenario or --out")
        print_crosscheck(crosscheck(*args.crosscheck))
        return EXIT_OK
    if not args.scenario or not args.out:
        raise ConfigError("scenario: give a scenario and --out (or --crosscheck RECORDING DIAGNOSIS_JSON)")
    study_filters(args.filters)  # a wrong --filters before minutes of computation
    out = Path(args.out)
    with _result_dir(args, out, inputs=(args.scenario,)) as tmp, _progress("online-study", args.quiet) as progress:
        res = online_study(args.scenario, tmp, args.duration, args.threads, filters=args.filters, progress=progress)
    print(f"filters: {', '.join(res['filters'])}; wrote {out}: online-study.json, online-study.md, "
          "online-estimates.png")
    return EXIT_OK


def _cmd_schema(args) -> int:
    from sins_sim.config.reference import FORMATS, render_markdown, render_text

    formats = [args.format] if args.format else list(FORMATS)
    if args.json_schema:
        from sins_sim.config.reference import render_json_schema

        if args.markdown:
            raise ConfigError("--json-schema: give either --json-schema or --markdown")
        if not args.format:
            raise ConfigError("--json-schema: name the format (scenario, imu, experiment, sweep or log)")
        sys.stdout.write(render_json_schema(args.format))
        return EXIT_OK
    if args.markdown:
        sys.stdout.write(render_markdown(formats))
    else:
        sys.stdout.write("\n".join(render_text(f) for f in formats))
    return EXIT_OK


def _cmd_navigate(args) -> int:
    from sins_sim.jobs.navigate import navigate_file

    metrics = navigate_file(args.increments, args.truth, args.out, name=args.name, coning=args.coning,
                            sculling=args.sculling, vertical=args.vertical, height_aid_tau_s=args.height_aid_tau,
                            align=args.align or ("truth" if args.truth else "inertial"),
                            align_duration_s=args.align_duration, imu=args.imu, site_lat_deg=args.site_lat_deg,
                            site_lon_deg=args.site_lon_deg, site_height_m=args.site_height_m, zupt=args.zupt,
                            force=args.force, manifest=_manifest(args))
    al = metrics.get("alignment") or metrics.get("filters", {}).get(args.name, {}).get("alignment")
    if al:
        err = (f"; against the truth {al['error_heading_deg']:+.4g} deg" if "error_heading_deg" in al else "")
        print(f"alignment {al['method']} over {al['duration_s']:g} s: heading {al['heading_deg']:.4f} deg "
              f"(sigma {al['sigma_heading_deg']:.3g} deg{err}), roll {al['roll_deg']:.4f}, pitch {al['pitch_deg']:.4f} deg")
    for note in metrics.get("notes", []):
        args.job_warnings.append(note)
    if "solution" in metrics:
        nav, sol = metrics["navigation"], metrics["solution"]
        f = sol["final_displacement_m"]
        print(f"navigated {nav['end_s'] - nav['start_s']:.6g} s at {nav['rate_hz']:.6g} Hz with no truth: displacement "
              f"from the start north {f['north']:.4g} m, east {f['east']:.4g} m, up {f['up']:.4g} m (horizontal "
              f"{f['horizontal']:.4g} m; for a unit that stood still, its navigation error)")
        z = metrics.get("zupt")
        if z:
            rms = ", ".join(f"{x:.3g}" for x in z["velocity_residual_rms_ned_m_s"])
            print(f"zero-velocity updates: {z['updates']}, residual RMS N, E, D {rms} m/s, mean NIS {z['nis_mean']:.3g} "
                  f"(3 expected); biases with their sigmas in metrics.json and report.md")
        print(f"wrote {args.out}: metrics.json, solution.parquet, alignment.png, displacement.png, report.md"
              + (", zupt.parquet" if z else ""))
        return EXIT_OK
    m, nav = metrics["filters"][args.name], metrics["navigation"]
    print(f"navigated {nav['end_s'] - nav['start_s']:.6g} s of increments at {nav['rate_hz']:.6g} Hz against "
          f"{args.truth} ({m['status']})")
    if m["status"] == "ok":
        att = m["attitude_error_arcsec"]["final"]
        print(f"final errors: horizontal {m['horizontal_position_error_m']['final']:.4g} m, vertical "
              f"{m['vertical_position_error_m']['final']:.4g} m, velocity {m['velocity_error_m_s']['final']:.4g} m/s, "
              f"attitude N,E,D {att['north']:.4g}, {att['east']:.4g}, {att['down']:.4g} arcsec")
        for key, label in (("gyro_drift_deg_h", "gyro drift x,y,z"), ("attitude_drift_deg_h", "attitude drift N,E,D")):
            d = m.get(key)
            if d:
                cells = [f"{d[ax]['value']:.4g}" if d[ax]["value"] is not None else d[ax]["status"]
                         for ax in d if ax != "rule"]
                print(f"{label} [deg/h]: {', '.join(cells)}")
    from pathlib import Path

    written = sorted(p.name for p in Path(args.out).iterdir() if not p.name.startswith(".") and p.is_file())
    print(f"wrote {args.out}: {', '.join(written)}")
    return EXIT_OK


def _cmd_import_log(args) -> int:
    from sins_sim.jobs.import_log import import_log, summary_lines

    meta = import_log(args.log, args.describe, args.out, force=args.force)
    for line in summary_lines(meta, args.out):
        print(line)
    return EXIT_OK


def _cmd_identify(args) -> int:
    from sins_sim.jobs.identify import identify, identify_positions, identify_rate_table, identify_truth

    if args.truth is not None:
        m = identify_truth(args.log, args.truth, args.out, twin_seeds=args.twin_seeds, force=args.force,
                           manifest=_manifest(args))
        tf = m["truth_fit"]
        for sensor, bkey in (("gyro", "bias_deg_h"), ("accelerometer", "bias_ug")):
            for group in (bkey, "scale_factor_ppm", "misalignment_arcsec"):
                cells = [f"{k} {e['value']:.4g} +- {e['sigma']:.2g}" if "value" in e else f"{k} not observable"
                         for k, e in tf[sensor][group].items()]
                print(f"{sensor} {group}: {'; '.join(cells)}")
        _print_twin(m)
        print(f"wrote {args.out}: {', '.join(sorted(m.files))}, manifest.json")
        return EXIT_OK
    if args.positions is not None:
        m = identify_positions(args.log, args.positions, args.out, lat_deg=args.site_lat_deg,
                               lon_deg=args.site_lon_deg, height_m=args.site_height_m, force=args.force,
                               manifest=_manifest(args))
        pf = m["positions_fit"]
        print("positions: " + ", ".join(f"{p['up']} {p['start_s']:.4g}-{p['end_s']:.4g} s" for p in pf["positions"]))
        for sensor, group in (("accelerometer", "bias_ug"), ("accelerometer", "scale_factor_ppm"),
                              ("accelerometer", "misalignment_arcsec"), ("gyro", "bias_deg_h"),
                              ("gyro", "g_sensitivity_deg_h_per_g")):
            cells = [f"{k} {e['value']:.4g} +- {e['sigma']:.2g}" for k, e in pf[sensor][group].items() if "value" in e]
            print(f"{sensor} {group}: {'; '.join(cells) or 'none determined'}")
        print(f"wrote {args.out}: {', '.join(sorted(m.files))}, manifest.json")
        return EXIT_OK
    if args.rate_table is not None:
        m = identify_rate_table(args.log, args.rate_table, args.out, force=args.force, manifest=_manifest(args))
        for group in ("scale_factor_ppm", "misalignment_arcsec"):
            cells = [f"{k} {e['value']:.4g} +- {e['sigma']:.2g}" if "value" in e else f"{k} {e['status']}"
                     for k, e in m["motion_terms"][group].items()]
            print(f"gyro {group}: {'; '.join(cells)}")
        print(f"wrote {args.out}: {', '.join(sorted(m.files))}, manifest.json")
        return EXIT_OK

    m = identify(args.log, args.out, lat_deg=args.site_lat_deg, lon_deg=args.site_lon_deg,
                 height_m=args.site_height_m, alignment=args.align, gyro_bias_prior_deg_h=args.gyro_bias_prior_deg_h,
                 accel_bias_prior_ug=args.accel_bias_prior_ug, twin_seeds=args.twin_seeds,
                 line_false_alarm=args.line_false_alarm, until_s=args.until_s, force=args.force,
                 manifest=_manifest(args))
    if m.invalid:       # a verdict, as diagnose's on invalid data: exit status 0, the folder says why
        print(m["summary"])
        if args.out is not None:
            print(f"wrote {args.out}: {', '.join(sorted(m.files))}, manifest.json")
        return EXIT_OK
    for sensor, key in (("gyro", "arw_deg_rt_h"), ("gyro", "rrw_deg_h_rt_h"), ("accelerometer", "vrw_ug_rt_hz")):
        cells = [f"{e['value']:.4g}" if "value" in e else e["status"] for e in
                 (m["noise"][sensor][ax][key] for ax in "xyz")]
        print(f"{sensor} {key} x, y, z: {', '.join(cells)}")
    for sensor, key in (("gyro", "north_deg_h"), ("gyro", "down_deg_h"), ("accelerometer", "down_ug")):
        e = m["bias"][sensor][key]
        if "value" not in e:
            print(f"{sensor} bias {key}: {e['status']}")
            continue
        sig = "sigma not determinable" if e.get("sigma") is None else f"+- {e['sigma']:.2g} (1 sigma)"
        print(f"{sensor} bias {key}: {e['value']:.4g} {sig}")
    n_lines = sum(len(e["lines"]) for s in ("gyro", "accelerometer") for e in m["lines"][s].values())
    print(f"spectral lines: {n_lines}")
    _print_twin(m)
    print(f"wrote {args.out}: {', '.join(sorted(m.files))}, manifest.json")
    return EXIT_OK


def _print_twin(m) -> None:
    """The twin's summary and its findings, one line each (identify, at rest or on a known trajectory)."""
    if "twin" in m:
        print(f"twin: {m['twin']['summary']}")
        for f in m["twin"]["findings"]:
            print(f"  {f['statement']}")
    v = m.get("verdict")
    if v:
        named = " + ".join(e["effect"] for e in v.get("effects", [])) or v["effect"]
        print(f"verdict: {v['status']}" + (f": {named} ({v['explained_fraction']:.2f} +- "
                                           f"{v['explained_fraction_sd']:.2f} of the gap)"
                                           if v["status"] in ("explained", "partly explained") else ""))


def _cmd_completion(args) -> int:
    from sins_sim.jobs.completion import completion_script

    sys.stdout.write(completion_script(build_parser(), args.shell))
    return EXIT_OK


class _Version(argparse.Action):
    """``--version``: the version, then where to read what changed (argparse's own action rewraps lines)."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS, help=None):
        super().__init__(option_strings, dest=dest, default=default, nargs=0, help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        from sins_sim._version import CHANGELOG

        sys.stdout.write(f"sins-sim {__version__}\nWhat changed in each version: {CHANGELOG} in the source "
                         "distribution and the repository.\n")
        parser.exit()


def _unit_flags(p) -> None:
    """``--duration``, ``--imu`` and ``--filter-parameters``: what a run or a budget may override."""
    p.add_argument("--duration", type=_positive, default=None, help="override the scenario's duration_s (s)")
    p.add_argument("--imu", default=None, help="override the scenario's IMU file (e.g. configs/nav-grade-rlg.yaml)")
    p.add_argument("--filter-parameters", default=None, choices=("true", "nominal"),
                   help="what the filters believe: the unit's true parameters or the datasheet's (nominal, f0 "
                        "from the dither PLL) [the scenario's]")


def _force_flag(p) -> None:
    p.add_argument("--force", action="store_true",
                   help="replace an existing result folder (only once the new result is complete)")


def _overrides(args) -> dict:
    out = {}
    for key, attr in (("seed", "seed"), ("duration_s", "duration"), ("imu", "imu"),
                      ("filter_parameters", "filter_parameters")):
        if getattr(args, attr, None) is not None:
            out[key] = getattr(args, attr)
    return out


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="sins-sim", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action=_Version, help="print the version and where to read what changed")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("channel", help="simulate one dithered RLG channel and both dither filters",
                       description="Simulate one dithered RLG channel (drive at the amplitude-dependent "
                                   "resonance, plant eq. 2, readout, filters at the filter rate) and write "
                                   "channel.png, metrics.json and timeseries.npz.")
    p.add_argument("--f0", type=float, default=386.0, help="small-amplitude resonance f0 (Hz) [386]")
    p.add_argument("--dither-arcmin", type=_positive, default=3.0, help="dither amplitude (arcmin) [3]")
    p.add_argument("--duration", type=_positive, default=2.0, help="simulated time (s) [2]")
    p.add_argument("--settle", type=_non_negative, default=None,
                   help="start-up transient excluded from the residual RMS (s) [min(1, duration/2)]")
    p.add_argument("--motion", choices=("none", "sine"), default="none", help="SINS motion [none]")
    p.add_argument("--motion-hz", type=_positive, default=100.0, help="sine motion frequency (Hz) [100]")
    p.add_argument("--motion-arcmin", type=_non_negative, default=1.0, help="sine motion amplitude (arcmin) [1]")
    p.add_argument("--k1", type=float, default=1.75e-4, help="eq. 9 k1 [1.75e-4]")
    p.add_argument("--k2", type=float, default=1.05e-3, help="eq. 9 k2 (rad) [1.05e-3]")
    p.add_argument("--k3", type=float, default=4.4e-3, help="eq. 10 k3 [4.4e-3]")
    p.add_argument("--k4", type=float, default=250.0, help="eq. 10 k4 (1/rad) [250]")
    p.add_argument("--k5", type=float, default=-1.2e-5, help="eq. 14 k5 (rad/V) [-1.2e-5]")
    p.add_argument("--quantum-arcsec", type=_positive, default=2.42 / 16,
                   help="readout quantum (arcsec) [2.42/16, the paper's interpolation; 2.42 = one fringe]")
    p.add_argument("--noise-arcsec", type=_non_negative, default=0.0, help="white readout noise std (arcsec) [0]")
    p.add_argument("--plant-rate", type=float, default=72000.0, help="plant and readout rate (Hz) [72000]")
    p.add_argument("--filter-rate", type=float, default=7200.0, help="decimated filter rate (Hz) [7200]")
    p.add_argument("--anti-alias", choices=("fir", "off"), default="fir", help="anti-alias low-pass [fir]")
    p.add_argument("--anti-alias-hz", type=float, default=9000.0, help="anti-alias cut-off (Hz) [9000]")
    p.add_argument("--hysteresis", choices=("paper", "masing"), default="paper",
                   help="eq. 10 half-cycle rule in plant and filter [paper]")
    p.add_argument("--seed", type=_seed, default=0, help="seed of the readout noise [0]")
    p.add_argument("--quiet", action="store_true", help="no progress bar (warnings are still printed)")
    p.add_argument("--out", required=True, help="output directory (created; an existing one only with --force)")
    _force_flag(p)
    p.set_defaults(func=_cmd_channel, flags=CHANNEL_FLAGS)

    p = sub.add_parser("run", help="run a three-axis SINS scenario (YAML) end to end",
                       description="Run a scenario file: three dithered channels, their filters, attitude "
                                   "integration and navigation error; writes metrics.json, timeseries.npz, "
                                   "report.md and the figures that have data: navigation_error.png, "
                                   "attitude_error.png, trajectory.png, gyro_error_spectrum.png (for filters other "
                                   "than ideal), allan.png (where a filter's gyro error has an Allan curve), "
                                   "and with an IMU block, block_spectrum.png and block_coning.png (two dithers "
                                   "that beat slowly); "
                                   "report.md lists the figures written. Also manifest.json (versions, command "
                                   "line, timings, input hashes, the parameters each filter used) and inputs/ (the "
                                   "scenario and IMU as run, for --rerun).")
    p.add_argument("scenario", nargs="?", default=None, help="scenario YAML file (see scenarios/)")
    p.add_argument("--out", required=True, help="output directory (created; an existing one only with --force)")
    p.add_argument("--rerun", metavar="DIR", default=None,
                   help="run the result folder DIR again from its manifest.json and inputs/ (no scenario file, no "
                        "overrides; --out must be another folder); says whether metrics.json is identical")
    p.add_argument("--seed", type=_seed, default=None, help="override the scenario's seed")
    _unit_flags(p)
    _force_flag(p)
    p.add_argument("--quiet", action="store_true", help="no progress bar (warnings are still printed)")
    p.set_defaults(func=_cmd_run)

    p = sub.add_parser("budget", help="the navigation error budget of a scenario, source by source",
                       description="Run the scenario with everything on, with each error source switched off in "
                                   "turn (each sensor-error term, readout quantisation and noise, accelerometer "
                                   "quantisation, filter parameter mismatch, each effect) and with every source "
                                   "off, in parallel; write budget.json, budget.png and report.md.")
    p.add_argument("scenario", help="scenario YAML file (see scenarios/)")
    p.add_argument("--out", required=True, help="output directory (created; an existing one only with --force)")
    _force_flag(p)
    p.add_argument("--seed", type=_seed, default=None, help="override the scenario's seed")
    _unit_flags(p)
    p.add_argument("--workers", type=_count, default=2, help="worker processes, one run each at a time [2]")
    p.add_argument("--quiet", action="store_true", help="no progress bar (warnings are still printed)")
    p.set_defaults(func=_cmd_budget)

    p = sub.add_parser("reproduce", help="regenerate the paper's figures and numbers with sins-sim's own code",
                       description="Figures 1, 3-7 and the Abel inversion (fig1_correcting_afc.png, "
                                   "fig3_resonance_vs_amplitude.png, fig3_abel_nonl.png, fig4_afc_fit.png, "
                                   "fig5_end_to_end_afc.png, fig6_mismatch.png, fig7_impact.png), the sensitivity "
                                   "table, numbers.json and a report.md comparing sins-sim with the paper.")
    p.add_argument("--out", required=True, help="output directory (created; an existing one only with --force)")
    _force_flag(p)
    p.add_argument("--quick", action="store_true", help="every number at reduced resolution (< 90 s)")
    p.add_argument("--quiet", action="store_true", help="no progress bar (warnings are still printed)")
    p.set_defaults(func=_cmd_reproduce)

    p = sub.add_parser("compare-filters", help="every correcting filter against the wideband targets (issue 15)",
                       description="End-to-end gain on the nonlinear plant, noise, delay, cost, coning drift and "
                                   "position error of eq. 5, the eliminator, the wideband designs and the production LMS stripper; gain.png, "
                                   "noise_tradeoff.png, details.json, report.md and the numbers (filters.json) in --out.")
    p.add_argument("--out", required=True, help="output directory (created; an existing one only with --force)")
    _force_flag(p)
    p.add_argument("--json", default=None, help="also write the numbers (issue 15 structure) here [only DIR/filters.json]")
    p.add_argument("--quick", action="store_true", help="reduced resolution and a 30 s mission (a few minutes)")
    p.add_argument("--imu", default=None, metavar="FILE",
                   help="your unit's IMU file (channels, resonances, readout, block) [configs/default-imu.yaml, or "
                        "the --scenario's own IMU]")
    p.add_argument("--scenario", default=None, metavar="FILE",
                   help="your mission for the position-error column (vibration, trajectory, duration; --imu replaces "
                        "its IMU) [scenarios/nav-stationary-1h.yaml]")
    p.add_argument("--quiet", action="store_true", help="no progress bar (warnings are still printed)")
    p.set_defaults(func=_cmd_compare_filters)

    p = sub.add_parser("simulate-recording", help="write a sins-sim-recording/1 file from an experiment YAML",
                       description="Simulate an experiment (stationary, afc_sweep, rate_table) with any effects "
                                   "switched on and write it in the recording format; the file says nothing about "
                                   "the effects. The YAML keys are listed in sins_sim/config/experiment.py.")
    p.add_argument("spec", help="experiment YAML")
    p.add_argument("--out", required=True, help="recording .npz to write")
    p.set_defaults(func=_cmd_simulate_recording)

    p = sub.add_parser("import-csv", help="convert a lab CSV export into a sins-sim-recording/1 file",
                       description="Columns: time_s, counts_<axis>..., drive_v_<axis>..., optional "
                                   "sins_angle_rad_<axis>... (see sins_sim/io/recording.py).")
    p.add_argument("csv", help="lab export (CSV)")
    p.add_argument("--out", required=True, help="recording .npz to write")
    p.add_argument("--quantum-arcsec", type=_positive, required=True, help="readout quantum (arcsec)")
    p.add_argument("--nominal", required=True, help="JSON or YAML file: axis -> {f0_hz, k1, k2, k3, k4, k5} "
                                                    "(or the configs/*.yaml names k2_rad, k4_per_rad, k5_rad_per_v)")
    p.add_argument("--experiment", default="stationary", help="experiment name [stationary]")
    p.add_argument("--initial-state", choices=("rest", "unknown"), default="rest", help="[rest]")
    p.add_argument("--description", default=None, help="free text for the header")
    p.add_argument("--fs-hz", type=_positive, default=None, help="sample rate (default: from time_s)")
    p.set_defaults(func=_cmd_import_csv)

    p = sub.add_parser("diagnose", help="where a recording and the model disagree, and which effect explains it",
                       description="Refit the nominal parameters per axis, localise the residual above the noise "
                                   "floor, fit each catalogue effect, rank them (penalised) and give a verdict.")
    p.add_argument("recording", nargs="+", help="sins-sim-recording/1 .npz (several: diagnosed in turn, or --jobs "
                                                "at once)")
    p.add_argument("--json", help="write the diagnosis JSON here (several recordings: a folder of STEM.json)")
    p.add_argument("--report", help="write report.md, spectrum.png, envelope.png and (when an effect was tried) "
                                    "ranking.png into this directory (several recordings: a folder of STEM/)")
    p.add_argument("--effects", help="comma-separated subset of the catalogue to try (default: all)")
    p.add_argument("--jobs", type=_count, default=1, help="recordings diagnosed at once, in separate processes [1]")
    p.add_argument("--suggest", help="when the verdict is a close call, write the experiment that separates it "
                                     "here (YAML for simulate-recording; one recording only)")
    _force_flag(p)
    p.set_defaults(func=_cmd_diagnose)

    p = sub.add_parser("diagnose-eval", help="blind evaluation of the diagnosis on generated recordings",
                       description="Recordings with each catalogue effect at random strengths, none cases and an "
                                   "off-catalogue disturbance, nominal parameters perturbed, labels hidden; prints "
                                   "a confusion matrix and gap-reduction statistics.")
    p.add_argument("--n", type=_count, required=True, help="number of recordings")
    p.add_argument("--seed", type=_seed, default=0, help="seed of the case generator [0]")
    p.add_argument("--duration", type=_positive, default=1.0, help="length of each recording (s) [1]")
    p.add_argument("--json", help="write the result JSON here")
    p.add_argument("--quiet", action="store_true", help="no per-case progress lines")
    p.add_argument("--jobs", type=_count, default=1, help="recordings diagnosed at once, in processes [1]")
    p.add_argument("--hard", action="store_true", help="the harder set: time gaps and sign flips under table motion, "
                                                       "bias drift, structural modes, near-degenerate pairs, "
                                                       "the Earth's rate, randomised units (identification.blind_hard)")
    p.add_argument("--seeds", help="comma-separated seeds instead of --seed: --n recordings each, accuracy pooled "
                                   "per class")
    p.add_argument("--holdout", action="store_true", help="with --hard: the two seeds kept unlooked-at during "
                                                          "development (blind_hard.HOLDOUT_SEEDS)")
    p.add_argument("--labels", help="comma-separated classes to draw (default all of the set's), e.g. "
                                    "earth_rate,near_degenerate with --hard")
    p.set_defaults(func=_cmd_diagnose_eval)

    p = sub.add_parser("identify-eval", help="blind evaluation of identify's twin verdict on generated unit logs",
                       description="Logs of random units with withheld effects, written in a foreign layout, "
                                   "imported and judged by identify; prints the accuracy per class. Groups: rest "
                                   "(one effect each: none, sway, vibration, bias step, two off-catalogue ones, a "
                                   "time gap), two (two effects at rest, right when explained naming both), moving "
                                   "(on a known trajectory, judged with --truth: none, scale-factor asymmetry, clock "
                                   "rate, an off-catalogue noise burst).")
    p.add_argument("--seeds", default="0,1,2", help="comma-separated seeds looked at [0,1,2]")
    p.add_argument("--holdout", action="store_true", help="also the two seeds kept unlooked-at during development "
                                                          "(jobs.identify_eval.HOLDOUT_SEEDS), reported apart")
    p.add_argument("--minutes", type=_positive, default=3.0, help="length of each log (min) [3]")
    p.add_argument("--twin-seeds", type=_count, default=5, help="seeds of each log's twin [5]")
    p.add_argument("--classes", default=None, help="comma-separated classes or groups (rest, two, moving) "
                                                   "[every class]")
    p.add_argument("--json", help="write the result JSON here")
    p.add_argument("--quiet", action="store_true", help="no per-case progress lines")
    p.set_defaults(func=_cmd_identify_eval)

    p = sub.add_parser("schema", help="every key of an input format with its unit, range and default",
                       description="Print the reference of an input format (scenario, imu, experiment, trajectory, "
                                   "sweep, log; "
                                   "default all), generated from the schemas; --markdown gives "
                                   "docs/scenario-reference.md.")
    p.add_argument("format", nargs="?", choices=("scenario", "imu", "experiment", "trajectory", "sweep", "log"),
                   default=None,
                   help="the format [all]")
    p.add_argument("--markdown", action="store_true", help="Markdown tables (docs/scenario-reference.md)")
    p.add_argument("--json-schema", action="store_true",
                   help="the format's JSON Schema (draft 2020-12) for editors: save it and put '# "
                        "yaml-language-server: $schema=PATH' on the first line of a YAML file")
    p.set_defaults(func=_cmd_schema)

    p = sub.add_parser("lockin-study", help="lock-in in the loop: dynamic lock-in and the ARW of dithered lock-in",
                       description="Run the engine's chain with the lock_in effect: ARW vs lock-in rate, dither "
                                   "amplitude and modulation depth beside N = Omega_L / sqrt(K a w_D), and the "
                                   "dynamic lock-in zones of a constant-amplitude dither; writes lockin.json, "
                                   "arw_vs_lockin.png, dynamic_lockin.png and report.md.")
    p.add_argument("--out", required=True, help="result folder (created; an existing one only with --force)")
    _force_flag(p)
    p.add_argument("--quick", action="store_true", help="shorter runs, fewer points (about 15 s)")
    p.add_argument("--seed", type=_seed, default=0, help="seed of the amplitude modulation [0]")
    p.set_defaults(func=_cmd_lockin_study)

    p = sub.add_parser("separation-study", help="how far apart must two dither resonances be on an isolated block",
                       description="Bring one axis's drive frequency towards another's on a unit whose IMU file has a "
                                   "block: section, run a mission per separation (at rest, or under a scenario's "
                                   "vibration), and report each filter's heading error (dither coning), the "
                                   "cross-axis dither line, the vibration lines' intermodulation with the dithers, "
                                   "and the drives on live PLLs (pulling, entrainment); writes separation.json, "
                                   "separation.csv, intermodulation.csv, pll_vibration.csv, separation.png and report.md.")
    p.add_argument("imu", help="IMU file with a block: section (e.g. configs/isolated-block.yaml)")
    p.add_argument("--out", required=True, help="result folder (created; an existing one only with --force)")
    _force_flag(p)
    p.add_argument("--pair", default="x,y", help="the axis that stays and the one brought towards it [x,y]")
    p.add_argument("--separations-hz", type=float, nargs="+", default=None,
                   help="drive-frequency separations to try (Hz) [40 20 10 5 2 1 0.5 0.2 0.1]")
    p.add_argument("--duration-s", type=float, default=30.0,
                   help="each mission's length (s); cover a few beats of the smallest separation [30]")
    p.add_argument("--start-s", type=float, default=2.0, help="navigation start (s) [2]")
    p.add_argument("--axis-offset-mrad", type=float, default=2.0,
                   help="tilt of the second gyro's input axis towards the first (mrad) [2]")
    p.add_argument("--budget-arcsec", type=float, default=0.05,
                   help="largest beat amplitude the dither coning may put into a filter's heading error (arcsec) "
                        "[0.05]")
    p.add_argument("--seed", type=_seed, default=1, help="seed of the runs [1]")
    p.add_argument("--scenario", default=None,
                   help="scenario file whose vibration (motion, linear_vibration, where they enter) the unit is under "
                        "[at rest]")
    p.add_argument("--pll-bandwidth-hz", type=float, default=5.0,
                   help="natural frequency of each drive's live PLL (Hz, at most 100) [5]")
    p.set_defaults(func=_cmd_separation_study)

    p = sub.add_parser("online-study", help="what learning the filters' parameters in operation buys",
                       description="Run a scenario whose filter_parameters source is online four times (online, "
                                   "true, nominal, nominal + PLL tracking) over every filter that takes parameters "
                                   "(eq. 5 in both forms and the wideband designs; --filters chooses), and report the "
                                   "estimator's convergence per axis and parameter and each filter's residual and "
                                   "navigation error per source: online-study.json, online-study.md and "
                                   "online-estimates.png in --out. --crosscheck sets the online estimate of a "
                                   "recording beside its diagnosis' refit.")
    from sins_sim.jobs.online_study import add_arguments as _online_arguments

    _online_arguments(p)
    _force_flag(p)
    p.add_argument("--quiet", action="store_true", help="no progress bar (warnings are still printed)")
    p.set_defaults(func=_cmd_online_study)

    p = sub.add_parser("sweep", help="Monte Carlo over a population of units on dask.distributed",
                       description="Run every (unit, scenario) of a sweep file (sins-sim schema sweep) as a "
                                   "dask.distributed task; write one Parquet part per finished run, runs.parquet, "
                                   "summary.json and figures into --out. A second invocation resumes: runs already "
                                   "done are not run again. Figures: distributions.png and, for scenarios with at "
                                   "least 3 runs and drawn parameters, sensitivity_<scenario>_<metric>.png.")
    p.add_argument("sweep", help="sweep YAML file (see scenarios/sweep-*.yaml)")
    p.add_argument("--out", default=None, help="sweep folder (created, or resumed when it holds this sweep); "
                                                "required but with --rerun, where it is the folder to compare with")
    p.add_argument("--rerun", default=None, metavar="RUN_ID",
                   help="run one run of the sweep alone in this process (its key in runs.parquet, or UNIT:SCENARIO, "
                        "e.g. 3:stationary), print its metrics and, with --out, compare it with the stored row")
    p.add_argument("--batch-size", type=_count, default=None,
                   help="runs per Dask task [chosen from the estimated run time: tasks of about 1 s, at least 4 "
                        "per worker thread, at most 64 runs]; the results do not depend on it")
    p.add_argument("--force", action="store_true",
                   help="run in a folder that holds another sweep (its stored runs stay as a cache; its table, "
                        "summary and figures are replaced)")
    p.add_argument("--scheduler", default=None,
                   help="address of a running dask scheduler (tcp://host:port) [a LocalCluster]")
    p.add_argument("--workers", type=_count, default=None,
                   help="LocalCluster worker processes, one thread each [the cores, at most the runs]")
    p.add_argument("--quiet", action="store_true", help="no progress bar (warnings are still printed)")
    p.set_defaults(func=_cmd_sweep)

    p = sub.add_parser("navigate", help="navigate external angle and velocity increments against a trajectory",
                       description="Navigate increments from another simulator or a logged IMU (CSV or Parquet: "
                                   "time_s, dtheta_x_rad, dtheta_y_rad, dtheta_z_rad, dv_x_m_s, dv_y_m_s, dv_z_m_s; "
                                   "body axes x forward, y right, z down; raw, not coning- or sculling-compensated; "
                                   "time_s is the end of each interval on the trajectory file's time axis, uniformly "
                                   "spaced) with sins-sim's strapdown navigator, aligned to the truth one period "
                                   "before the first row or by an alignment (--align) over the first "
                                   "--align-duration seconds; write metrics.json with the error metrics of run "
                                   "(position, velocity, attitude, psi and attitude drift, gyro drift per axis). "
                                   "Without --truth (a unit's own log, from sins-sim import-log): align, navigate "
                                   "and write the solution, its displacement from the start and the figures.")
    p.add_argument("increments", help="increments file (.csv, .parquet)")
    p.add_argument("--truth", default=None, help="trajectory file (sins-sim schema trajectory) the increments "
                                                 "were taken along; without it (a unit's own log) the result is the "
                                                 "solution itself, from an alignment")
    p.add_argument("--align", choices=("truth", "coarse", "inertial", "kalman"), default=None,
                   help="how the starting attitude is found: from the truth, or by aligning over the first "
                        "--align-duration seconds of the increments (the unit at rest there) [truth with --truth, "
                        "else inertial]")
    p.add_argument("--align-duration", type=_positive, default=300.0, help="alignment window (s) [300]")
    p.add_argument("--imu", default=None, help="IMU file whose sensors: section gives the bias bounds and noise the "
                                               "alignment states its sigma from (sins-sim schema imu)")
    p.add_argument("--site-lat-deg", type=float, default=None, help="site latitude (deg) [the table's, from "
                                                                   "import-log]")
    p.add_argument("--site-lon-deg", type=float, default=None, help="site longitude (deg) [the table's]")
    p.add_argument("--site-height-m", type=float, default=None, help="site height above the ellipsoid (m) "
                                                                     "[the table's]")
    p.add_argument("--zupt", action="store_true", help="the log stood still: after the alignment, navigate with "
                                                       "zero-velocity updates and report the velocity residuals and "
                                                       "the biases each with its sigma (needs --imu; no --truth)")
    p.add_argument("--out", required=True, help="output directory (created; an existing one only with --force)")
    p.add_argument("--name", default="external", help="the name of the result in metrics.json [external]")
    p.add_argument("--coning", choices=("none", "two_sample", "three_sample", "four_sample"), default="two_sample",
                   help="coning compensation [two_sample]")
    p.add_argument("--sculling", choices=("none", "two_sample", "three_sample", "four_sample"), default="two_sample",
                   help="sculling compensation [two_sample]")
    p.add_argument("--vertical", choices=("height_aid", "free"), default="height_aid",
                   help="vertical channel: aided by the truth's height, or free [height_aid]")
    p.add_argument("--height-aid-tau", type=_positive, default=100.0, help="height-aid time constant (s) [100]")
    _force_flag(p)
    p.set_defaults(func=_cmd_navigate)

    p = sub.add_parser("import-log", help="convert a unit's own log (counts, its axes) into an increments file",
                       description="Read a strapdown unit's log (text, CSV or Parquet: pulse counts, increments or "
                                   "rates per interval, in the unit's own axes) as a YAML description says "
                                   "(sins-sim schema log), check its time base (duplicate rows dropped, gaps "
                                   "refused or filled), and write a Parquet increments file in body axes x forward, "
                                   "y right, z down that sins-sim navigate reads, with the description, the site, "
                                   "the source's SHA-256 and the report in its metadata.")
    p.add_argument("log", help="the unit's log")
    p.add_argument("--describe", required=True, help="the log's description (YAML; sins-sim schema log)")
    p.add_argument("--out", required=True, help="increments file to write (.parquet; an existing one only with "
                                                "--force)")
    p.add_argument("--force", action="store_true", help="replace an existing --out (once the new file is complete)")
    p.set_defaults(func=_cmd_import_log)

    p = sub.add_parser("identify", help="fit a unit from its log at rest and run its twin beside it",
                       description="From an increments file of a unit at rest (sins-sim import-log): the overlapping "
                                   "Allan deviation of each gyro and accelerometer axis with the IEEE Std 952 terms "
                                   "(95 %% intervals, 'not determinable' where a term has no slope region), the "
                                   "biases observable at rest against the Earth's rate and normal gravity ('not "
                                   "observable' for the others), the PSD's spectral lines, the temperature "
                                   "coefficients where the log has a temperature_c column, a sensors: section for "
                                   "the unit's twin, and the twin simulated beside the log (Allan deviation, PSD, "
                                   "alignment, free navigation) with where the log leaves its envelope. A log that "
                                   "fails the data checks (time order, gaps, uneven steps, a rate off its nominal, "
                                   "a stuck or saturated channel) gets the verdict 'invalid data': one line on "
                                   "stdout, the folder with metrics.json and report.md naming the check, the row and "
                                   "the remedy, exit status 0 (as diagnose on invalid data).")
    p.add_argument("log", help="increments file (from sins-sim import-log)")
    p.add_argument("--out", required=True, help="result folder to write")
    p.add_argument("--site-lat-deg", type=float, default=None, help="site latitude (deg) [from the log]")
    p.add_argument("--site-lon-deg", type=float, default=None, help="site longitude (deg) [from the log]")
    p.add_argument("--site-height-m", type=float, default=None, help="site height (m) [from the log]")
    p.add_argument("--align", choices=("coarse", "inertial"), default="coarse", help="alignment method [coarse]")
    p.add_argument("--gyro-bias-prior-deg-h", type=float, default=0.01,
                   help="1-sigma gyro bias before the log, for the unobservable part's coupling (deg/h) [0.01]")
    p.add_argument("--accel-bias-prior-ug", type=float, default=100.0,
                   help="1-sigma accelerometer bias before the log, for the tilt's coupling (ug) [100]")
    p.add_argument("--rate-table", default=None, metavar="SEGMENTS.csv",
                   help="the log is a rate-table run: windows of constant rate (start_s, end_s, axis, rate_deg_s); "
                        "gives the gyro scale factors and misalignments from the reversal pairs instead")
    p.add_argument("--truth", default=None, metavar="TRAJECTORY",
                   help="the log moved on this known trajectory (a trajectory file, as navigate --truth): gives the "
                        "biases, scale factors and misalignments the motion excites, by least squares on the log's "
                        "increments less the trajectory's ideal ones")
    p.add_argument("--positions", nargs="?", const="auto", default=None, metavar="POSITIONS.csv",
                   help="the log is a multi-position (tumble) test: still windows (start_s, end_s, optionally up: +x, "
                        "-x, ...), found from the log when no file is given; gives the accelerometer biases, scale "
                        "factors and misalignments and the gyro biases and g-sensitivity instead")
    p.add_argument("--twin-seeds", type=int, default=5,
                   help="seeds of the twin simulated beside the log; 0: no twin [5]")
    p.add_argument("--line-false-alarm", type=float, default=0.01,
                   help="chance of one or more false spectral lines in the whole log [0.01]")
    p.add_argument("--until-s", type=float, default=None,
                   help="fit the log's first seconds only (a log still at first, then moving) [the whole log]")
    _force_flag(p)
    p.set_defaults(func=_cmd_identify)

    p = sub.add_parser("completion", help="print a shell completion script (bash or zsh)",
                       description="Print a completion script for sins-sim's commands, flags and choices, "
                                   "generated from this parser. Install it with eval \"$(sins-sim completion "
                                   "bash)\" in ~/.bashrc, or eval \"$(sins-sim completion zsh)\" in ~/.zshrc.")
    p.add_argument("shell", choices=("bash", "zsh"), help="the shell")
    p.set_defaults(func=_cmd_completion)

    p = sub.add_parser("bench", help="measure the per-sample cost of the kernels and the three-axis chain")
    p.add_argument("--quick", action="store_true", help="short inputs, few repeats")
    p.add_argument("--json", help="write the results as JSON to this file")
    p.set_defaults(func=_cmd_bench)
    return parser


# --- the one way out ------------------------------------------------------------------------------
def _on_sigterm(signum, frame):
    raise KeyboardInterrupt


@contextmanager
def _sigterm_interrupts():
    """SIGTERM raises KeyboardInterrupt while the command runs (main thread only; restored after)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGTERM, _on_sigterm)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def _error(message: str) -> None:
    sys.stderr.write(f"sins-sim: error: {_one_line(message)}\n")


def _internal(exc: BaseException) -> str:
    if isinstance(exc, MemoryError):
        return f"out of memory{': ' + _one_line(exc) if str(exc) else ''} (try a shorter --duration)"
    if isinstance(exc, OSError):
        where = f"{exc.filename}: " if getattr(exc, "filename", None) else ""
        return f"{where}{exc.strerror or _one_line(exc) or type(exc).__name__}"
    return (f"internal error ({type(exc).__name__}: {_one_line(exc)}); set {DEBUG_ENV}=1 for the traceback "
            "and please report it")


def _print_warnings(job_warnings, caught, flags=None) -> None:
    for line in format_warning_lines([*job_warnings, *caught]):
        sys.stderr.write(_name_flags(line, flags) + "\n")
    sys.stderr.flush()


def main(argv=None) -> int:
    """Run the command line; return the exit status (argparse's ``--help``/``--version`` exit via SystemExit)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    args.argv = list(sys.argv[1:] if argv is None else argv)
    args.job_warnings = []
    debug = os.environ.get(DEBUG_ENV, "").strip() not in ("", "0")
    try:
        with _sigterm_interrupts():
            with capture_warnings() as caught:
                try:
                    return args.func(args)
                finally:
                    _print_warnings(args.job_warnings, caught, getattr(args, "flags", None))
    except KeyboardInterrupt:
        if debug:
            raise
        sys.stderr.write("sins-sim: interrupted\n")
        return EXIT_INTERRUPTED
    except ValueError as exc:  # ConfigError, RecordingError and every parameter rule
        if debug:
            raise
        _error(_name_flags(_one_line(exc), getattr(args, "flags", None)))
        return EXIT_USAGE
    except BrokenPipeError:  # the reader of stdout went away (| head): nothing left to tell it
        try:
            sys.stdout = open(os.devnull, "w")
        except OSError:
            pass
        return EXIT_INTERNAL
    except Exception as exc:  # noqa: BLE001 - the last line of defence: one line, no traceback
        if debug:
            raise
        _error(_internal(exc))
        return EXIT_INTERNAL


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
