"""The full fuzz tier: ``python -m tests.fuzz.run --n 1000 [--seed S] [--jobs 2] [--timeout 120] [--json F]``.

Every case goes through the ``sins-sim`` command line in its own subprocess (``run`` for scenario, IMU and
trajectory files, ``simulate-recording`` for experiments, ``diagnose`` for recordings, ``channel`` for flags),
killed after ``--timeout`` seconds. Counts per class, per kind, per outcome and per verdict are printed and
written to ``--json`` (default ``fuzz-results.json``) with every failing case. ``--budget-s`` stops starting
new cases after that many seconds (the cases run are reported). Exit status 1 when any case failed.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor, as_completed
from dataclasses import asdict
from pathlib import Path

from .generate import all_kinds, generate
from .harness import format_summary, run_cli, summarize


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m tests.fuzz.run", description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, default=1000, help="number of cases [1000]")
    p.add_argument("--seed", type=int, default=1, help="seed of the generator [1]")
    p.add_argument("--jobs", type=int, default=2, help="cases run at once [2]")
    p.add_argument("--timeout", type=float, default=120.0, help="seconds per case before it counts as a hang [120]")
    p.add_argument("--budget-s", type=float, default=None, help="start no new case after this many seconds")
    p.add_argument("--kinds", default=None, help=f"comma-separated subset of {','.join(all_kinds())}")
    p.add_argument("--json", default="fuzz-results.json", help="where to write the counts [fuzz-results.json]")
    p.add_argument("--keep", default=None, help="keep every case's folder under this directory")
    p.add_argument("--rejudge", default=None, metavar="JSON",
                   help="judge the outcomes stored in an earlier --json again with the current expectations and gaps "
                        "(no case is run), and rewrite it")
    args = p.parse_args(argv)
    if args.rejudge:
        return rejudge(Path(args.rejudge))
    kinds = args.kinds.split(",") if args.kinds else None
    t0 = time.perf_counter()
    cases = generate(args.n, args.seed, kinds)
    print(f"{len(cases)} cases generated in {time.perf_counter() - t0:.1f} s (seed {args.seed})", flush=True)
    base = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="sins-fuzz-full-"))
    results, skipped = [], 0
    start = time.perf_counter()

    def one(case):
        if args.budget_s is not None and time.perf_counter() - start > args.budget_s:
            return None
        return run_cli(case, base / case.id, timeout=args.timeout)

    with ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        futures = [pool.submit(one, case) for case in cases]
        for k, fut in enumerate(as_completed(futures), 1):
            r = fut.result()
            if r is None:
                skipped += 1
                continue
            results.append(r)
            if r.verdict not in ("ok", "known_gap"):
                print(f"  {r.id} {r.kind}/{r.cls}: {r.verdict}: {r.what}: {r.message[:160]}", flush=True)
            if k % 50 == 0:
                print(f"{k}/{len(cases)} done, {time.perf_counter() - start:.0f} s", flush=True)
    seconds = time.perf_counter() - start
    results.sort(key=lambda r: r.id)
    summary = summarize(results)
    summary["run"] = {"n_generated": len(cases), "n_run": len(results), "n_skipped_by_budget": skipped,
                      "seed": args.seed, "jobs": args.jobs, "timeout_s": args.timeout, "seconds": round(seconds, 1),
                      "mean_case_s": round(sum(r.seconds for r in results) / max(len(results), 1), 2),
                      "python": platform.python_version(), "machine": platform.machine()}
    print(format_summary(summary))
    print(f"{len(results)} cases in {seconds:.0f} s ({skipped} not started: budget); "
          f"{len(summary['failures'])} failing, {len(summary['known_gaps'])} known gap(s)")
    Path(args.json).write_text(json.dumps(summary, indent=1) + "\n")
    print(f"wrote {args.json}")
    return 1 if summary["failures"] else 0


def rejudge(path: Path) -> int:
    """Re-judge a results file: the outcomes stay, the expectations and gaps come from the generator as it is now.

    A results file without the full ``results`` list (written before it was kept) is re-judged from its
    ``failures`` and ``known_gaps``: every other case was judged ``ok``, which no rule here can change.
    """
    from .harness import Result, judge, known_defect

    old = json.loads(path.read_text())
    run = old.get("run", {})
    cases = {c.id: c for c in generate(run["n_generated"], run["seed"])}

    def again(d):
        case = cases[d["id"]]
        gap = case.gap or known_defect(d["message"])
        return Result(d["id"], case.kind, case.cls, case.expect, case.what, d["outcome"],
                      judge(case.expect, d["outcome"], case.gap, d["message"]), d["message"], d["seconds"], gap)

    if "results" in old:
        results = [again(d) for d in old["results"]]
        summary = summarize(results)
    else:
        summary = old
        for d in old["failures"]:
            r = again(d)
            if r.verdict == d["verdict"]:
                continue
            for table, key in ((summary["per_class"], r.cls), (summary["per_kind"], r.kind)):
                table[key]["verdicts"][d["verdict"]] -= 1
                table[key]["verdicts"][r.verdict] += 1
            summary["totals"]["verdicts"][d["verdict"]] -= 1
            summary["totals"]["verdicts"][r.verdict] += 1
            summary["failures"] = [f for f in summary["failures"] if f["id"] != r.id]
            (summary["known_gaps"] if r.verdict == "known_gap" else summary["failures"]).append(asdict(r))
    summary["run"] = {**run, "rejudged": True}
    path.write_text(json.dumps(summary, indent=1) + "\n")
    print(format_summary(summary))
    print(f"rejudged {path}: {len(summary['failures'])} failing, {len(summary['known_gaps'])} known gap(s)")
    return 1 if summary["failures"] else 0


if __name__ == "__main__":
    sys.exit(main())
