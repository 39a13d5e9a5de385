"""Command-line interface: thin argument parsing over the scenario and identification layers.

Bad input (an unphysical parameter, an inconsistent setting) is reported as
one line, ``sins-sim: error: <field>: <rule>``, with exit status 2.
"""

from __future__ import annotations

import argparse
import sys

__all__ = ["main", "build_parser"]


def _progress(label: str):
    """A one-line progress bar on stderr for runs longer than a blink."""
    state = {"last": -1}

    def update(fraction: float) -> None:
        pct = int(100 * fraction)
        if pct != state["last"]:
            state["last"] = pct
            bar = "#" * (pct // 4)
            sys.stderr.write(f"\r{label} [{bar:<25}] {pct:3d}%")
            if pct >= 100:
                sys.stderr.write("\n")
            sys.stderr.flush()

    return update


def _cmd_channel(args) -> int:
    from sins_sim.models.drive import DriveParams
    from sins_sim.models.plant import PlantSettings
    from sins_sim.models.readout import AntiAliasParams, ReadoutParams
    from sins_sim.models.suspension import SuspensionParams
    from sins_sim.jobs.channel import make_motion, run_channel_job
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
    metrics = run_channel_job(config, args.duration, motion, args.out, settle_s=args.settle, seed=args.seed,
                              progress=_progress("channel") if not args.quiet else None)
    rms = metrics["residual_rms_arcsec"]
    print(f"drive {metrics['drive']['frequency_hz']:.3f} Hz, {metrics['drive']['v_m']:.4g} V; "
          f"Q = {metrics['suspension']['q_at_amplitude']:.1f}")
    print("residual RMS vs true SINS angle (arcsec): " + ", ".join(f"{k} {val:.4g}" for k, val in rms.items()))
    print(f"wrote {args.out}/channel.png, metrics.json, timeseries.npz")
    return 0


def _cmd_run(args) -> int:
    from pathlib import Path

    from sins_sim.jobs.scenario import run_scenario

    out = Path(args.out)
    metrics = run_scenario(args.scenario, out, progress=None if args.quiet else _progress(Path(args.scenario).stem))
    print(f"{'filter':<18}{'|drift| deg/h':>14}{'RMS err arcsec (x,y,z)':>34}{'pos. 1 h (m)':>14}")
    for name, m in metrics["filters"].items():
        rms = ", ".join(f"{x:.3g}" for x in m["attitude_error_rms_arcsec"])
        print(f"{name:<18}{m['drift_norm_deg_per_h']:>14.4g}{rms:>34}{m['position_error_1h_m']:>14.4g}")
    for w in metrics["warnings"]:
        print(f"warning: {w}")
    print(f"report: {out / 'report.md'}")
    return 0


def _cmd_reproduce(args) -> int:
    from pathlib import Path

    from sins_sim.jobs.reproduce import run_reproduce

    out = Path(args.out)
    run_reproduce(out, quick=args.quick, progress=None if args.quiet else _progress("reproduce"))
    print(f"report: {out / 'report.md'}; numbers: {out / 'numbers.json'}")
    return 0


def _cmd_bench(args) -> int:
    import json

    from sins_sim.benchmarking import format_table, run_bench

    result = run_bench(quick=args.quick)
    print(format_table(result))
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(result, fh, indent=2)
        print(f"wrote {args.json}")
    return 0


def _cmd_simulate_recording(args) -> int:
    from sins_sim.jobs.recording_jobs import simulate_recording

    info = simulate_recording(args.spec, args.out)
    print(f"wrote {info.get('path', args.out)}")
    return 0


def _cmd_import_csv(args) -> int:
    from sins_sim.jobs.recording_jobs import import_csv

    info = import_csv(args.csv, args.out, quantum_arcsec=args.quantum_arcsec, nominal=args.nominal,
                      experiment=args.experiment, initial_state=args.initial_state, description=args.description,
                      fs_hz=args.fs_hz)
    print(f"wrote {info['path']}: axes {', '.join(info['axes'])}, {info['n_samples']} samples at "
          f"{info['fs_hz']:g} Hz ({info['duration_s']:g} s)")
    return 0


def _cmd_diagnose(args) -> int:
    from sins_sim.jobs.recording_jobs import diagnose, format_diagnosis

    effects = args.effects.split(",") if args.effects else None
    result = diagnose(args.recording, json_out=args.json, report_dir=args.report, effects=effects)
    print(format_diagnosis(result))
    return 0


def _cmd_diagnose_eval(args) -> int:
    from sins_sim.jobs.recording_jobs import diagnose_eval, format_eval

    progress = None if args.quiet else (lambda line: print(line, file=sys.stderr, flush=True))
    result = diagnose_eval(args.n, args.seed, duration_s=args.duration, json_out=args.json, progress=progress)
    print(format_eval(result))
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="sins-sim", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("channel", help="simulate one dithered RLG channel and both dither filters",
                       description="Simulate one dithered RLG channel (drive at the amplitude-dependent "
                                   "resonance, plant eq. 2, readout, filters at the filter rate) and write "
                                   "channel.png, metrics.json and timeseries.npz.")
    p.add_argument("--f0", type=float, default=386.0, help="small-amplitude resonance f0 (Hz) [386]")
    p.add_argument("--dither-arcmin", type=float, default=3.0, help="dither amplitude (arcmin) [3]")
    p.add_argument("--duration", type=float, default=2.0, help="simulated time (s) [2]")
    p.add_argument("--settle", type=float, default=1.0,
                   help="start-up transient excluded from the residual RMS (s) [1]")
    p.add_argument("--motion", choices=("none", "sine"), default="none", help="SINS motion [none]")
    p.add_argument("--motion-hz", type=float, default=100.0, help="sine motion frequency (Hz) [100]")
    p.add_argument("--motion-arcmin", type=float, default=1.0, help="sine motion amplitude (arcmin) [1]")
    p.add_argument("--k1", type=float, default=1.75e-4, help="eq. 9 k1 [1.75e-4]")
    p.add_argument("--k2", type=float, default=1.05e-3, help="eq. 9 k2 (rad) [1.05e-3]")
    p.add_argument("--k3", type=float, default=4.4e-3, help="eq. 10 k3 [4.4e-3]")
    p.add_argument("--k4", type=float, default=250.0, help="eq. 10 k4 (1/rad) [250]")
    p.add_argument("--k5", type=float, default=-1.2e-5, help="eq. 14 k5 (rad/V) [-1.2e-5]")
    p.add_argument("--quantum-arcsec", type=float, default=2.42 / 16,
                   help="readout quantum (arcsec) [2.42/16, the paper's interpolation; 2.42 = one fringe]")
    p.add_argument("--noise-arcsec", type=float, default=0.0, help="white readout noise std (arcsec) [0]")
    p.add_argument("--plant-rate", type=float, default=72000.0, help="plant and readout rate (Hz) [72000]")
    p.add_argument("--filter-rate", type=float, default=7200.0, help="decimated filter rate (Hz) [7200]")
    p.add_argument("--anti-alias", choices=("fir", "off"), default="fir", help="anti-alias low-pass [fir]")
    p.add_argument("--anti-alias-hz", type=float, default=9000.0, help="anti-alias cut-off (Hz) [9000]")
    p.add_argument("--hysteresis", choices=("paper", "masing"), default="paper",
                   help="eq. 10 half-cycle rule in plant and filter [paper]")
    p.add_argument("--seed", type=int, default=0, help="seed of the readout noise [0]")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--out", required=True, help="output directory")
    p.set_defaults(func=_cmd_channel)

    p = sub.add_parser("run", help="run a three-axis SINS scenario (YAML) end to end",
                       description="Run a scenario file: three dithered channels, their filters, attitude "
                                   "integration and navigation error; writes metrics.json, timeseries.npz, "
                                   "attitude_error.png, spectrum.png and report.md.")
    p.add_argument("scenario", help="scenario YAML file (see scenarios/)")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_run)

    p = sub.add_parser("reproduce", help="regenerate the paper's figures and numbers with sins-sim's own code",
                       description="Figures 1, 3-7, the Abel inversion, the sensitivity table, numbers.json and "
                                   "a report.md comparing sins-sim with the paper.")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--quick", action="store_true", help="every number at reduced resolution (< 90 s)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_reproduce)

    p = sub.add_parser("simulate-recording", help="write a sins-sim-recording/1 file from an experiment YAML",
                       description="Simulate an experiment (stationary, afc_sweep, rate_table) with any effects "
                                   "switched on and write it in the recording format; the file says nothing about "
                                   "the effects. The YAML keys are listed in sins_sim/jobs/recording_jobs.py.")
    p.add_argument("spec", help="experiment YAML")
    p.add_argument("--out", required=True, help="recording .npz to write")
    p.set_defaults(func=_cmd_simulate_recording)

    p = sub.add_parser("import-csv", help="convert a lab CSV export into a sins-sim-recording/1 file",
                       description="Columns: time_s, counts_<axis>..., drive_v_<axis>..., optional "
                                   "sins_angle_rad_<axis>... (see sins_sim/io/recording.py).")
    p.add_argument("csv", help="lab export (CSV)")
    p.add_argument("--out", required=True, help="recording .npz to write")
    p.add_argument("--quantum-arcsec", type=float, required=True, help="readout quantum (arcsec)")
    p.add_argument("--nominal", required=True, help="JSON or YAML file: axis -> {f0_hz, k1, k2, k3, k4, k5}")
    p.add_argument("--experiment", default="stationary", help="experiment name [stationary]")
    p.add_argument("--initial-state", choices=("rest", "unknown"), default="rest", help="[rest]")
    p.add_argument("--description", default=None, help="free text for the header")
    p.add_argument("--fs-hz", type=float, default=None, help="sample rate (default: from time_s)")
    p.set_defaults(func=_cmd_import_csv)

    p = sub.add_parser("diagnose", help="where a recording and the model disagree, and which effect explains it",
                       description="Refit the nominal parameters per axis, localise the residual above the noise "
                                   "floor, fit each catalogue effect, rank them (penalised) and give a verdict.")
    p.add_argument("recording", help="sins-sim-recording/1 .npz")
    p.add_argument("--json", help="write the diagnosis JSON here")
    p.add_argument("--report", help="write report.md and PNGs into this directory")
    p.add_argument("--effects", help="comma-separated subset of the catalogue to try (default: all)")
    p.set_defaults(func=_cmd_diagnose)

    p = sub.add_parser("diagnose-eval", help="blind evaluation of the diagnosis on generated recordings",
                       description="Recordings with each catalogue effect at random strengths, none cases and an "
                                   "off-catalogue disturbance, nominal parameters perturbed, labels hidden; prints "
                                   "a confusion matrix and gap-reduction statistics.")
    p.add_argument("--n", type=int, required=True, help="number of recordings")
    p.add_argument("--seed", type=int, default=0, help="seed of the case generator [0]")
    p.add_argument("--duration", type=float, default=1.0, help="length of each recording (s) [1]")
    p.add_argument("--json", help="write the result JSON here")
    p.add_argument("--quiet", action="store_true", help="no per-case progress lines")
    p.set_defaults(func=_cmd_diagnose_eval)

    p = sub.add_parser("bench", help="measure the per-sample cost of the kernels and the three-axis chain")
    p.add_argument("--quick", action="store_true", help="short inputs, few repeats")
    p.add_argument("--json", help="write the results as JSON to this file")
    p.set_defaults(func=_cmd_bench)
    return parser


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except ValueError as exc:
        sys.stderr.write(f"sins-sim: error: {exc}\n")
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
