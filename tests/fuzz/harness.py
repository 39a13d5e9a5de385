"""Run fuzz cases and judge them: in-process (validation only, fast tier) or through the command line (full tier).

Outcomes of a run: ``accepted``; ``refused`` (one clean line naming a field: a ConfigError or ValueError
in-process, exit status 2 with one ``sins-sim: error:`` line from the CLI); ``refused_unnamed`` (refused,
but the message names no key, flag, row or column); ``traceback`` (any other exception, an internal error,
a crash); ``hang`` (the per-case timeout ran out).

Verdicts against the case's expectation: ``ok``; ``traceback``; ``hang``; ``silent_acceptance`` (an
invalid input accepted); ``valid_rejected``; ``unnamed``; ``internal`` (a refusal in the code's words:
``__init__``, "unexpected keyword argument", ...); ``known_gap`` (an invalid input accepted where
the case names the module that cannot tell today, see ``generate.Case.gap``).
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
import traceback
import warnings
from dataclasses import asdict, dataclass
from pathlib import Path

OUTCOMES = ("accepted", "refused", "refused_unnamed", "traceback", "hang")
VERDICTS = ("ok", "traceback", "hang", "silent_acceptance", "valid_rejected", "unnamed", "internal", "known_gap")

#: a key path, a flag, an argparse argument, a row, line or column, followed by ": "
_FIELD = re.compile(r"(?:^|: )(?:[A-Za-z_][\w\-]*(?:\[[^\]]*\])*(?:\.[\w\-]+(?:\[[^\]]*\])*)*|--[\w-]+|argument [\w-]+"
                    r"|row \d+[^:]*|line \d+[^:]*|column [\w]+)(?:: |:$)")


#: what a refusal of a whole file names instead of a key: the key in quotes, the line, byte or position, the top level
_PLACE = re.compile(r"key '[^']*'|\blines? \d+|\bbyte \d+|\bposition \d+|the top level|unrecognized arguments: "
                    r"|the following arguments are required: ")


_CONTEXT = re.compile(r"^(?:recording |trajectory file )?(?:\S*[/\\]\S*|\S+\.(?:ya?ml|npz|csv|parquet|pq|json))"
                      r"(?: -> \S+)*: ")
_LEADING = re.compile(r"^(?:--[\w-]+|argument [\w-]+|row \d+[^:]*|column \S+|[^\s:]+(?: \([^)]*\))?): \S")


def names_field(message: str) -> bool:
    """Whether a refusal names what is wrong: a key path, a flag, a row, line, column, byte, or the top level.

    The file a message starts with does not count: after it must come the key (or flag, row, column), then
    ``": "`` and the rule.
    """
    if _PLACE.search(message):
        return True
    m = _CONTEXT.match(message)
    rest = message[m.end():] if m else message
    return bool(_LEADING.match(rest) or _FIELD.search(rest))


@dataclass
class Result:
    id: str
    kind: str
    cls: str
    expect: str
    what: str
    outcome: str
    verdict: str
    message: str
    seconds: float
    gap: str | None = None


#: Tracebacks found by the fuzz in modules outside this suite's reach, by a pattern of their message: counted
#: as ``known_gap`` (and listed) until the module is fixed; the pattern then stops matching.
#: Message fragments of known reader defects still open (the zlib.error of a corrupted deflate stream is fixed:
#: read_recording reports it as corrupted data naming the member).
KNOWN_DEFECTS: dict = {}


def known_defect(message: str) -> str | None:
    return next((why for pattern, why in KNOWN_DEFECTS.items() if pattern in message), None)


#: Words of Python or of the code's insides that a refusal must not show the user (issue 40: "AxisCoupling.__init__()
#: got an unexpected keyword argument", "only the SINS engine runs it", "NoneType.__format__").
_INTERNAL = re.compile(r"__\w+__|unexpected keyword argument|positional argument|object has no attribute|NoneType"
                       r"|is not callable|unhashable type|Traceback|internal error|only the SINS engine")


def internal_words(message: str) -> str | None:
    """The first internal word of a refusal's message, or None."""
    m = _INTERNAL.search(message)
    return m.group(0) if m else None


def judge(expect: str, outcome: str, gap: str | None, message: str = "") -> str:
    if outcome in ("refused", "refused_unnamed") and internal_words(message):
        return "internal"
    if outcome == "traceback" and known_defect(message):
        return "known_gap"
    if outcome in ("hang", "traceback") and gap:  # the gap names why (see generate.GAP_FS)
        return "known_gap"
    if outcome in ("traceback", "hang"):
        return outcome
    if gap and outcome == "accepted" and expect != "valid":
        return "known_gap"
    if outcome == "refused_unnamed":
        return "valid_rejected" if expect == "valid" else "unnamed"
    if expect == "valid":
        return "ok" if outcome == "accepted" else "valid_rejected"
    if expect == "invalid" and outcome == "accepted":
        return "known_gap" if gap else "silent_acceptance"
    return "ok"


class _Hang(BaseException):
    """The per-case timeout (a BaseException, so that no ``except Exception`` swallows it)."""


@contextlib.contextmanager
def _alarm(seconds: float):
    def handler(signum, frame):
        raise _Hang()

    previous = signal.signal(signal.SIGALRM, handler)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, previous)


def _validate(case, folder: Path) -> str | None:
    """Load and check one case as the command would, without running any engine; the CLI's message or None."""
    from sins_sim.io.recording import read_recording
    from sins_sim.jobs.estimate import check_run
    from sins_sim.config.experiment import experiment_from_dict
    from sins_sim.config.scenario import load_scenario
    from sins_sim.config.yaml_io import load_yaml
    from sins_sim.models.plant import PlantSettings
    from sins_sim.simulation.experiment import FIT_SETTINGS, ExperimentInputs, suspension_from_nominal

    path = case.write(folder)
    if case.family is not None:
        from .families import families

        validate = families()[case.family].validate
        if validate is not None:
            validate(folder)
        return None
    if case.kind in ("scenario", "imu", "trajectory"):
        check_run(load_scenario(folder / "scenario.yaml"))
    elif case.kind == "experiment":
        experiment_from_dict(load_yaml(path), str(path))
    elif case.kind == "recording":
        rec = read_recording(path)
        for a in rec.axes:  # what ``diagnose`` builds first
            suspension_from_nominal(rec.nominal[a])
        PlantSettings(rate_hz=ExperimentInputs.from_recording(rec).plant_rate(FIT_SETTINGS))
    else:  # channel: the real command in-process (a valid case runs its 0.3 s job)
        from sins_sim.cli import main

        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            try:
                rc = main(["channel", *case.args, "--out", str(folder / "out"), "--quiet"])
            except SystemExit as exc:  # argparse: --help, bad flags
                rc = exc.code
        lines = [ln for ln in err.getvalue().splitlines() if ln.startswith("sins-sim: error: ")]
        if rc == 0:
            return None
        if rc == 2 and lines:
            raise _Refused(lines[-1][len("sins-sim: error: "):])
        raise RuntimeError(f"channel exited {rc}: {err.getvalue().strip()[-300:]}")
    return None


class _Refused(ValueError):
    pass


def run_in_process(case, timeout: float = 10.0) -> Result:
    """The fast tier: validation only, in this process, with a timeout."""
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="sins-fuzz-") as tmp:
        try:
            with warnings.catch_warnings(), _alarm(timeout):
                warnings.simplefilter("ignore")
                _validate(case, Path(tmp))
            outcome, message = "accepted", ""
        except _Hang:
            outcome, message = "hang", f"no answer within {timeout:g} s"
        except ValueError as exc:  # ConfigError, RecordingError, TrajectoryFileError, every parameter rule
            message = " ".join(str(exc).split())
            outcome = "refused" if names_field(message) and "\n" not in str(exc).strip() else "refused_unnamed"
        except Exception as exc:  # noqa: BLE001 - what the fuzz looks for
            tb = traceback.extract_tb(exc.__traceback__)[-1]
            outcome, message = "traceback", f"{type(exc).__name__}: {exc} ({Path(tb.filename).name}:{tb.lineno})"
    return Result(case.id, case.kind, case.cls, case.expect, case.what, outcome,
                  judge(case.expect, outcome, case.gap, message), message[:500], time.perf_counter() - t0,
                  case.gap or known_defect(message))


def cli_command(case, folder: Path) -> list:
    exe = [sys.executable, "-m", "sins_sim.cli"]
    path = folder / case.main if case.main else folder
    if case.family is not None:
        from .families import families

        return exe + families()[case.family].command(folder)
    if case.kind in ("scenario", "imu", "trajectory"):
        return exe + ["run", str(folder / "scenario.yaml"), "--out", str(folder / "out"), "--quiet"]
    if case.kind == "experiment":
        return exe + ["simulate-recording", str(path), "--out", str(folder / "rec.npz")]
    if case.kind == "recording":
        return exe + ["diagnose", str(path), "--json", str(folder / "diagnosis.json")]
    return exe + ["channel", *case.args, "--out", str(folder / "out"), "--quiet"]


def run_cli(case, folder: Path, timeout: float = 120.0) -> Result:
    """The full tier: the case through ``sins-sim`` in a subprocess, killed after ``timeout`` seconds."""
    case.write(folder)
    cmd = cli_command(case, folder)
    env = {k: v for k, v in os.environ.items() if k != "SINS_SIM_DEBUG"}
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, cwd=folder, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env,
                            start_new_session=True)
    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        return Result(case.id, case.kind, case.cls, case.expect, case.what, "hang", "hang",
                      f"no answer within {timeout:g} s", time.perf_counter() - t0, case.gap)
    seconds = time.perf_counter() - t0
    text = err.decode(errors="replace")
    errors = [ln for ln in text.splitlines() if ln.startswith("sins-sim: error: ")]
    if "Traceback" in text or proc.returncode not in (0, 2):
        outcome = "traceback"
        tail = text.strip().splitlines()
        message = errors[-1] if errors else (tail[-1] if tail else f"exit status {proc.returncode}")
    elif proc.returncode == 0:
        outcome, message = "accepted", ""
    else:
        message = errors[-1][len("sins-sim: error: "):] if errors else text.strip()[-300:]
        outcome = "refused" if len(errors) == 1 and names_field(message) else "refused_unnamed"
    return Result(case.id, case.kind, case.cls, case.expect, case.what, outcome,
                  judge(case.expect, outcome, case.gap, str(message)), str(message)[:500], seconds,
                  case.gap or known_defect(str(message)))


def summarize(results) -> dict:
    """Counts per kind and per class (outcomes and verdicts apart), totals, the failures and the known gaps."""
    from .generate import all_classes, all_kinds

    def row(rs):
        return {"cases": len(rs), "outcomes": {o: sum(r.outcome == o for r in rs) for o in OUTCOMES},
                "verdicts": {v: sum(r.verdict == v for r in rs) for v in VERDICTS}}

    return {"totals": row(results),
            "per_class": {c: row([r for r in results if r.cls == c]) for c in all_classes() if any(r.cls == c for r in results)},
            "per_kind": {k: row([r for r in results if r.kind == k]) for k in all_kinds() if any(r.kind == k for r in results)},
            "failures": [asdict(r) for r in results if r.verdict not in ("ok", "known_gap")],
            "known_gaps": [asdict(r) for r in results if r.verdict == "known_gap"],
            "results": [asdict(r) for r in results]}


def format_summary(summary: dict) -> str:
    """The counts as a table: outcomes (accepted, refused) and verdicts (what failed, what is a known gap)."""
    cols = [("cases", None), ("accepted", "outcomes"), ("refused", "outcomes"), ("ok", "verdicts"),
            ("silent_acceptance", "verdicts"), ("valid_rejected", "verdicts"), ("unnamed", "verdicts"),
            ("internal", "verdicts"), ("traceback", "verdicts"), ("hang", "verdicts"), ("known_gap", "verdicts")]
    titles = ("cases", "accepted", "refused", "ok", "silent", "valid-rej", "unnamed", "internal", "traceback", "hang",
              "gap")

    def cells(r):
        return "".join(f"{(r[c] if g is None else r[g][c]):>10}" for c, g in cols)

    lines = [f"{'':<28}" + "".join(f"{t:>10}" for t in titles)]
    for title, table in (("class", summary["per_class"]), ("kind", summary["per_kind"])):
        for name, r in table.items():
            lines.append(f"{title + ' ' + name:<28}" + cells(r))
    lines.append(f"{'total':<28}" + cells(summary["totals"]))
    return "\n".join(lines)
