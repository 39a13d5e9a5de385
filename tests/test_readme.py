"""The README stays a front page (issue 23): under 150 lines, the quick start first.

The two quick-start commands are a contract that CI runs (``.ci/run``), so they must be the README's first
code block, exactly; everything else lives in the documentation site (``docs/``).
"""

import json
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
QUICK_START = [
    "pip install -e . && sins-sim run scenarios/nav-trajectory-file.yaml --out out/nav-trajectory-file",
    'pip install -e ".[test]" && pytest',
]


def _code_blocks(text: str) -> list[list[str]]:
    return [block.strip("\n").splitlines() for block in re.findall(r"^```[^\n]*\n(.*?)^```", text, re.M | re.S)]


def test_readme_under_150_lines():
    n = len(README.read_text(encoding="utf-8").splitlines())
    assert n < 150, f"README.md has {n} lines; move detail into docs/ (issue 23: at most 150)"


def test_quick_start_is_the_first_code_block():
    blocks = _code_blocks(README.read_text(encoding="utf-8"))
    assert blocks, "README.md has no code block"
    assert blocks[0] == QUICK_START


def test_quick_start_matches_ci():
    """The second quick-start command is the one .ci/run executes."""
    assert QUICK_START[1] in (ROOT / ".ci" / "run").read_text(encoding="utf-8")


def test_code_block_parser_sees_a_wrong_first_block():
    """The check can fail: a README whose first block differs is told apart."""
    assert _code_blocks("```bash\npip install sins-sim\n```\n")[0] != QUICK_START


def test_readme_figure_exists_and_is_small():
    for rel in re.findall(r"!\[[^\]]*\]\(([^)]+)\)", README.read_text(encoding="utf-8")):
        path = ROOT / rel
        assert path.is_file(), rel
        assert path.stat().st_size < 200_000, f"{rel}: {path.stat().st_size} bytes; keep the README figure under 200 kB"


# --- every sins-sim command of the README runs (issue 40) -----------------------------------------------------------
# A README command names a placeholder (SCENARIO.yaml, DIR, unit.log, ...) where the user puts their own file. Each
# one is mapped here to a bundled file or to one this test makes; a new README command with an unmapped upper-case
# placeholder fails below, one with an unmapped input file fails when it runs (the file is missing: exit 2).
PLACEHOLDERS = {
    "SCENARIO.yaml": "scenarios/stationary.yaml",
    "IMU.yaml": "configs/nav-grade-rlg.yaml",
    "SWEEP.yaml": "made:sweep.yaml",  # scenarios/sweep-smoke.yaml cut to two units at rest for 1.5 s
    "EXP.yaml": "made:experiment.yaml",  # experiments/experiment-example.yaml cut to 0.25 s (diagnose: >= 0.2 s)
    "lab.csv": "made:lab.csv",  # the recording of simulate-recording exported as a lab CSV
    "nominal.yaml": "made:nominal.yaml",  # that recording's nominal parameters
    "inc.csv": "made:inc.csv",  # ideal increments of the bundled flight, 20 s at 100 Hz
    "flight.csv": "scenarios/trajectories/short-flight.csv",
    "unit.log": "scenarios/logs/rlg-unit7.log",
    "unit.yaml": "scenarios/logs/rlg-unit7.yaml",
    "DIR": "out/{command}-{n}",  # a new result folder for each command
    "N": "1",
    "S": "2",
}
# The quick form of each command: flags added or overriding the README's values (the README's own flags kept). A key
# "command --flag" applies only when the README's line gives that flag.
QUICK = {
    "run": {"--duration": "3"},  # nav-trajectory-file.yaml starts navigating at 2 s
    "budget": {"--duration": "2"},
    "separation-study": {"--duration-s": "3.5", "--separations-hz": ["20", "60"]},  # start 2 s + 1 s at least
    "diagnose-eval": {"--n": "1", "--duration": "0.3"},
    "sweep": {"--workers": "1"},  # tests/test_sweep.py runs the command on a 2-worker LocalCluster
    "navigate --align": {"--align-duration": "20"},  # the bundled log lasts 40 s; the default window is 300 s
    "online-study": {"--duration": "1.5", "--threads": "1"},  # four variants of 1.5 s (start 1 s, 0.1 s updates)
}


def _readme_commands(text: str) -> list[tuple[str, list[str], str | None]]:
    """Every ``sins-sim ...`` command of the code blocks (also after ``&&``) as (line, arguments, stdout file):
    the comment cut, ``[--flag VALUE]`` written out, ``[a|b]`` its first choice, ``> file`` the output file."""
    import shlex

    out = []
    for lang, block in re.findall(r"^```([^\n]*)\n(.*?)^```", text, re.M | re.S):
        if lang.strip() not in ("bash", "sh", "console", ""):
            continue
        for line in block.splitlines():
            code = re.split(r"\s{2,}#|\s#\s", line)[0]
            for part in code.split("&&"):
                part = part.strip()
                if not part.startswith("sins-sim "):
                    continue
                part, _, redirect = part.partition(">")
                part = re.sub(r"\[([^\]|]*)\|[^\]]*\]", r"\1", part).replace("[", "").replace("]", "")
                out.append((line, shlex.split(part)[1:], redirect.strip() or None))
    return out


def _quick(args: list[str]) -> list[str]:
    args = list(args)
    flags = {k: v for key, table in QUICK.items() for k, v in table.items()
             if key.split()[0] == args[0] and all(f in args for f in key.split()[1:])}
    for flag, value in flags.items():
        values = value if isinstance(value, list) else [value]
        if flag in args:
            i = args.index(flag)
            n = 1
            while i + 1 + n < len(args) and not args[i + 1 + n].startswith("-") and isinstance(value, list):
                n += 1
            args[i + 1:i + 1 + n] = values
        else:
            args += [flag, *values]
    return args


def _make(name: str, cwd: Path) -> str:
    """The files the placeholders marked ``made:`` stand for, written into ``cwd``."""
    import numpy as np
    import yaml

    path = cwd / name
    if name == "sweep.yaml":
        doc = yaml.safe_load((ROOT / "scenarios" / "sweep-smoke.yaml").read_text(encoding="utf-8"))
        doc.update(units=2, scenarios=[{"path": str(ROOT / "scenarios" / "stationary.yaml"), "duration_s": 1.5}])
        path.write_text(yaml.safe_dump(doc), encoding="utf-8")
    elif name == "experiment.yaml":
        src = ROOT / "scenarios" / "experiments" / "experiment-example.yaml"
        path.write_text(src.read_text(encoding="utf-8").replace("duration_s: 1.0", "duration_s: 0.25"))
    elif name in ("lab.csv", "nominal.yaml"):
        from sins_sim.io.recording import read_recording

        rec = read_recording(cwd / "rec.npz")  # written by the README's simulate-recording line before
        t = rec.time()
        cols = ",".join(f"counts_{a},drive_v_{a}" for a in rec.axes)
        rows = [f"{t[i]:.9f}," + ",".join(f"{rec.counts[i, j]},{float(rec.drive_v[i, j])!r}"
                                           for j in range(len(rec.axes))) for i in range(rec.n_samples)]
        (cwd / "lab.csv").write_text(f"time_s,{cols}\n" + "\n".join(rows) + "\n")
        (cwd / "nominal.yaml").write_text(yaml.safe_dump({a: dict(rec.nominal[a]) for a in rec.axes}))
    elif name == "inc.csv":
        from sins_sim.io import read_trajectory
        from sins_sim.jobs.navigate import write_increments
        from sins_sim.models.motion import SampledTrajectory
        from sins_sim.simulation.external import ideal_increments

        flight = SampledTrajectory.from_data(read_trajectory(ROOT / PLACEHOLDERS["flight.csv"]))
        t = 2.0 + np.arange(1, 20 * 100 + 1) / 100.0
        write_increments(path, t, *ideal_increments(flight, t))
    else:
        raise KeyError(name)
    return name


def _unmapped(commands) -> list[str]:
    """The upper-case names (``DIR``, ``FILE.yaml``) of the commands that PLACEHOLDERS does not map."""
    tokens = {a for _, args, _ in commands for a in args}
    return sorted(a for a in tokens if re.fullmatch(r"[A-Z][A-Z0-9_]*(\.\w+)?", a) and a not in PLACEHOLDERS)


def test_every_readme_command_has_its_placeholders_mapped():
    commands = _readme_commands(README.read_text(encoding="utf-8"))
    assert len(commands) >= 20 and commands[0][1][:2] == ["run", "scenarios/nav-trajectory-file.yaml"]
    tokens = {a for _, args, _ in commands for a in args}
    unmapped = _unmapped(commands)
    assert not unmapped, f"README placeholders without a file in PLACEHOLDERS: {unmapped}"
    stale = sorted(set(PLACEHOLDERS) - tokens)
    assert not stale, f"PLACEHOLDERS maps names no README command uses: {stale}"
    assert not {key.split()[0] for key in QUICK} - {args[0] for _, args, _ in commands}


def test_readme_command_parser_sees_chains_redirects_and_options():
    text = ("```bash\npip install -e . && sins-sim run A.yaml --out DIR  # x\n"
            "sins-sim schema [a|b] --json > s.json\n```\n")
    assert _readme_commands(text) == [
        ("pip install -e . && sins-sim run A.yaml --out DIR  # x", ["run", "A.yaml", "--out", "DIR"], None),
        ("sins-sim schema [a|b] --json > s.json", ["schema", "a", "--json"], "s.json")]
    assert _quick(["separation-study", "c.yaml", "--separations-hz", "1", "2", "3", "--out", "D"]) == [
        "separation-study", "c.yaml", "--separations-hz", "20", "60", "--out", "D", "--duration-s",
        QUICK["separation-study"]["--duration-s"]]
    assert _unmapped(_readme_commands("```\nsins-sim run NEW.yaml --out DIR --seed N\n```\n")) == ["NEW.yaml"]
    assert _quick(["navigate", "i.csv", "--out", "D"]) == ["navigate", "i.csv", "--out", "D"]  # no --align: none


def _scratch_checkout(tmp_path, monkeypatch):
    """Work in ``tmp_path`` with the repository's configs/ and scenarios/ reachable as the README writes them."""
    for d in ("configs", "scenarios"):
        (tmp_path / d).symlink_to(ROOT / d, target_is_directory=True)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")


def test_every_readme_command_runs(tmp_path, monkeypatch, capsys):
    """Each ``sins-sim`` command of the README in order, in one folder where configs/ and scenarios/ are
    reachable as written, through :func:`sins_sim.cli.main`; exit status 0 for each."""
    from sins_sim.cli import main

    _scratch_checkout(tmp_path, monkeypatch)
    # compare-filters --quick takes half a minute; tests/test_wideband.py runs that resolution in full, so here the
    # command's plumbing runs at the coarser one tests/test_figures.py uses for the figures
    import dataclasses

    from sins_sim.jobs import compare_filters as cf

    tiny = dataclasses.replace(cf.CompareSettings.quick_(), n_gain=4, mission_s=6.0, cost_samples=4000)
    monkeypatch.setattr(cf.CompareSettings, "quick_", classmethod(lambda cls: tiny))
    failures, n_dir = [], 0
    for line, args, redirect in _readme_commands(README.read_text(encoding="utf-8")):
        run = []
        for a in args:
            if a == "DIR":
                n_dir += 1
                a = PLACEHOLDERS["DIR"].format(command=args[0], n=n_dir)
            elif a in PLACEHOLDERS:
                target = PLACEHOLDERS[a]
                a = _make(target[5:], tmp_path) if target.startswith("made:") else target
            run.append(a)
        run = _quick(run)
        try:
            status = main(run)
        except SystemExit as exc:
            status = exc.code
        captured = capsys.readouterr()
        if redirect:  # the shell's `> file`: the command's standard output, which must be all there is of it
            Path(redirect).write_text(captured.out)
            if not captured.out.strip():
                failures.append(f"{line!r}: nothing written to {redirect}")
        if status not in (0, None):
            failures.append(f"{line!r} -> sins-sim {' '.join(run)}: exit {status}: {captured.err.strip()[-300:]}")
    assert not failures, "\n".join(failures)
    assert json.loads(Path("scenario.schema.json").read_text())["$schema"]  # the redirected one is the JSON schema


def test_readme_python_example_runs(tmp_path, monkeypatch):
    """The "From Python" block as written (its 60 s run is already a short one), then what it says it wrote."""
    blocks = re.findall(r"^```python\n(.*?)^```", README.read_text(encoding="utf-8"), re.M | re.S)
    assert len(blocks) == 1
    _scratch_checkout(tmp_path, monkeypatch)
    import matplotlib

    matplotlib.use("Agg")
    import sins_sim

    names = {}
    exec(compile(blocks[0], "README.md (From Python)", "exec"), names)
    assert set(names["frames"]) >= {"summary", "correcting"} and "filter" in names["ds"].dims
    assert sins_sim.load("out/first").to_pandas()["summary"].equals(names["frames"]["summary"])
