"""
Diagnosis of a recording
========================

``sins-sim simulate-recording`` writes a ``sins-sim-recording/1`` file of a bench experiment with its
effects hidden; ``sins-sim diagnose`` refits the nominal parameters, estimates the noise floor, localises
the gap and names the effect that closes it. Its report holds ``spectrum.png`` (the residual's spectrum
against the floor), ``envelope.png`` (where in time the gap sits) and ``ranking.png`` (the candidate
effects by the gap each closes). Here ``scenarios/experiments/experiment-example.yaml``: two axes on a
rate table for 1 s, a piezo lag on x that the diagnosis is not told about.
"""

import json
import tempfile
from pathlib import Path

from sins_sim.jobs.recording_jobs import diagnose, simulate_recording

ROOT = next(p for p in (Path.cwd(), *Path.cwd().parents) if (p / "scenarios").is_dir())
work = Path(tempfile.mkdtemp())
simulate_recording(ROOT / "scenarios" / "experiments" / "experiment-example.yaml", work / "rec.npz")
out = work / "diagnosis"
result = diagnose(work / "rec.npz", report_dir=out)
print(json.dumps(result["verdict"], indent=1, default=str)[:1500])
