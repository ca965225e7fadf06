#!/usr/bin/env python3
"""Regression test: the long runs' results name the engine each evaluation ran on.

Guards bd28d19's fix: the pair trains on MuJoCo and its snapshots are
evaluated there, but the in-progress orderings were labelled "rapier" and
`finish` put the best snapshot's test evaluation in the rapier rows. Uses
the pair's own MuJoCo snapshot evaluations from docs/results/paper_budget.
Runs in a second (CI's `long-runs-engines` stage); no build needed.
"""

import shutil
import sys
import tempfile
from pathlib import Path

root = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(root / "scripts"))
import long_runs_final  # noqa: E402
import long_runs_record  # noqa: E402

SNAP = "epoch-024.test.json"


def fixture(run):
    """The run's MuJoCo snapshot evaluation, in its record or, once archived, a lost one's."""
    for p in sorted((root / "docs/results").glob(f"paper_budget*/{run}*/snapshots/{SNAP}")):
        if p.parent.parent.name in (run,) or p.parent.parent.name.startswith(run + "-"):
            if long_runs_final.read_json(p).get("engine") == "mujoco":
                return p
    sys.exit(f"test_long_runs_engines: no MuJoCo {SNAP} of {run} under docs/results/paper_budget*")


mujoco = {run: fixture(run) for run in ("egg_dense_fmsr_is", "egg_dense")}

# The best snapshot lands in the rows of the engine it was evaluated on, only.
e = long_runs_final.read_json(mujoco["egg_dense"])
assert long_runs_final.engine_of(e) == "mujoco", e.get("engine")
r = {"best_test": e}
assert long_runs_final.best_on(r, "mujoco") is e
assert long_runs_final.best_on(r, "rapier") is None, "a MuJoCo evaluation in the rapier rows"
assert long_runs_final.best_on({"best_test": None}, "rapier") is None
# An evaluation written before the field existed was on rapier.
assert long_runs_final.engine_of({}) == "rapier"
assert long_runs_final.engine_name(e) == "MuJoCo"
assert long_runs_final.trained_on([{"finals": {"test-rapier": {"trained_on": "mujoco"}}}]) == "MuJoCo"

# The in-progress orderings name MuJoCo for MuJoCo evaluations.
with tempfile.TemporaryDirectory() as tmp:
    runs = []
    for run, label in (("egg_dense_fmsr_is", "Dense+FMSR+IS"), ("egg_dense", "Dense")):
        d = Path(tmp, run)
        (d / "snapshots").mkdir(parents=True)
        shutil.copyfile(mujoco[run], d / "snapshots" / SNAP)
        runs.append({"label": label, "dir": d, "snapshots": [(24, {"test": True})]})
    lines = long_runs_record.latest_orderings(runs)
    heading = next(line for line in lines if line.startswith("The paper's orderings"))
    assert "fixed test set (MuJoCo," in heading, heading
    assert "rapier" not in heading.split("(", 1)[1].split(";", 1)[0], heading

print("test_long_runs_engines: passed")
