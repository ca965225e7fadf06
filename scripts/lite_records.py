#!/usr/bin/env python3
"""Copy a finished lite arm's records into the repository (issue 52's E2/E3/E5).

    scripts/lite_records.py --run R --records D [--log L] [--policy P]

R is the run directory `scripts/lite_arm.sh` trained, evaluated and exported
(`$HOME/.local/share/fmsr/<experiment>/runs/<run>`); D its records under
docs/results/<experiment>/<run>. Writes into D:

- config.toml, provenance.json, metrics.csv and restarts.jsonl (when the run
  was restarted from a rescue point), as they are;
- eval.json, eval-validation.json and eval-<other engine>.json without the
  per-episode grasp summaries and the per-step trace (`episode_summaries`,
  `trace`: about nine tenths of the bytes), compact, by long_runs_record.py's
  `trim` (the long runs' snapshots are kept alike); every other field,
  the per-episode records with their final orientation included, kept;
- with --log (the arm's `lite_arm.sh` output), eval.log: the log from the
  last line that starts the training (`training ...`, `restarting ...`)
  before the first table, to its end: Table I and II's rows, holding still,
  and the other distance's count for each evaluation.

With --policy P, also copies R/policy.fmsr to P (to commit under pretrained/).
Refuses a run that has not been evaluated: the records are of a finished arm.
"""

import argparse
import os
import shutil
import sys
from pathlib import Path

from long_runs_record import trim, write_atomic  # the long runs' snapshots are trimmed alike

COPIED = ("config.toml", "provenance.json", "metrics.csv", "restarts.jsonl")


def eval_log(log_path):
    with open(log_path) as f:
        lines = f.read().splitlines()
    first_table = next((i for i, l in enumerate(lines) if l.startswith("| Task")), None)
    if first_table is None:
        raise SystemExit(f"{log_path}: no evaluation table in the log")
    start = 0
    for i in range(first_table):
        if lines[i].startswith(("training ", "restarting ")):
            start = i
    return "\n".join(lines[start:]) + "\n"


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--run", required=True)
    p.add_argument("--records", required=True)
    p.add_argument("--log")
    p.add_argument("--policy")
    a = p.parse_args()

    evals = sorted(f for f in os.listdir(a.run) if f.startswith("eval") and f.endswith(".json"))
    for needed in ("eval.json", "eval-validation.json"):
        if needed not in evals:
            sys.exit(f"{a.run}: no {needed}: evaluate the arm first (scripts/lite_arm.sh)")
    os.makedirs(a.records, exist_ok=True)
    for f in COPIED:
        src = os.path.join(a.run, f)
        if os.path.exists(src):
            shutil.copyfile(src, os.path.join(a.records, f))
    for f in evals:
        out = Path(a.records, f)
        write_atomic(out, Path(a.run, f).read_text())
        trim(out)
    if a.log:
        write_atomic(Path(a.records, "eval.log"), eval_log(a.log))
    if a.policy:
        src = os.path.join(a.run, "policy.fmsr")
        if not os.path.exists(src):
            sys.exit(f"{a.run}: no policy.fmsr: export the arm first (scripts/lite_arm.sh)")
        os.makedirs(os.path.dirname(a.policy) or ".", exist_ok=True)
        shutil.copyfile(src, a.policy + ".tmp")
        os.replace(a.policy + ".tmp", a.policy)
    print(f"{a.run}: records in {a.records}" + (f", policy at {a.policy}" if a.policy else ""))


if __name__ == "__main__":
    main()
