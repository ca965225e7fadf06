#!/usr/bin/env python3
"""Regression test: the restart twins' table compares what it says.

Guards scripts/restart_twins.py, which sets each arm restarted from a rescue
point against the `uninterrupted` twin of the same checkpoint (docs/notebook/results.md
"Not run": a late restart against the same run uninterrupted). On made-up run
directories whose answer is known: only the epochs from the split count (the
history before it, which every twin shares, does not); rates are read as counts
of the config's episodes an epoch; a restarted arm that fell by 30 points has
that difference, the reference none; arms that trained different epochs, a
missing reference, a gap in the epochs and a missing column are refused by
name, not compared, as is a restarted arm that split elsewhere than EPOCH0
(on the command line too); OUT/split (rescue points, no metrics) is no arm. Runs in
a second (CI's `restart-twins` stage).
"""

import json
import subprocess
import sys
import tempfile
from pathlib import Path

root = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(root / "scripts"))
import restart_twins as rt  # noqa: E402

CONFIG = "[trainer]\nseed = 0\neval_episodes = 50\ncycles = 50\nepisodes_per_cycle = 4\n"


def fail(msg):
    print(f"FAIL: {msg}", file=sys.stderr)
    sys.exit(1)


def refused(call, words, what):
    """`call` must raise a ValueError whose message holds `words`; `what` is what it would have done else."""
    try:
        call()
    except ValueError as e:
        if words not in str(e):
            fail(f"{what}: refused without naming {words!r}: {e}")
        return
    fail(f"{what}: not refused")


def arm(out, name, evals, trains, first=0, test=None):
    """OUT/name: a run whose epoch first + i has eval success evals[i] and training success trains[i]."""
    d = out / name
    d.mkdir(parents=True)
    (d / "config.toml").write_text(CONFIG)
    rows = ["epoch,success_rate,train_success_rate"]
    rows += [f"{first + i},{e},{t}" for i, (e, t) in enumerate(zip(evals, trains))]
    (d / "metrics.csv").write_text("\n".join(rows) + "\n")
    if test is not None:
        (d / "eval.json").write_text(json.dumps({"outcomes": {"successes": test[0], "episodes": test[1]}}))
    return d


with tempfile.TemporaryDirectory() as tmp:
    out = Path(tmp) / "twins"
    out.mkdir()
    (out / "twins.env").write_text("EPOCH0=3\nRUN=/nowhere\n")
    # Epochs 0-2 are the shared history (0 % for the reference, 100 % for the
    # restart: were they counted, the restart would look better); from 3 on the
    # restart's training success is 30 points below the reference's.
    arm(out, "uninterrupted", [0, 0, 0, 0.5, 0.5], [0, 0, 0, 0.6, 0.6], test=(80, 100))
    arm(out, "online", [1, 1, 1, 0.5, 0.5], [1, 1, 1, 0.3, 0.3], test=(70, 100))
    (out / "split").mkdir()
    (out / "split" / "config.toml").write_text(CONFIG)
    # The restarted arm's restart at the split, after one the source had at epoch 1.
    (out / "online" / "restarts.jsonl").write_text('{"restart": {"epoch": 1}}\n{"restart": {"epoch": 3}}\n')
    if rt.epoch0(out) != 3:
        fail(f"EPOCH0 of twins.env is 3, read {rt.epoch0(out)}")
    ref = rt.arm_counts(out / "uninterrupted", 3)
    if ref != ((50, 100), (240, 400), 2, (80, 100)):
        fail(f"2 epochs from 3 of 50 eval and 200 training episodes at 0.5 and 0.6, test 80 of 100: {ref}")
    lines = rt.table({"uninterrupted": ref, "online": rt.arm_counts(out / "online", 3)}, 3)
    text = "\n".join(lines)
    if "epochs 3-4" not in text:
        fail(f"the table should name the epochs it pooled (3-4):\n{text}")
    online = next(line for line in lines if line.startswith("| online |"))
    cells = [c.strip() for c in online.strip("|").split("|")]
    if cells[2] != "+0 pts [-14, +14]" or not cells[4].startswith("-30 pts") or not cells[6].startswith("-10 pts"):
        fail(f"online: eval +0, train -30, test -10 points against the reference: {online}")
    reference = next(line for line in lines if line.startswith("| uninterrupted |"))
    if reference.count("reference") != 3:
        fail(f"the reference is compared with nothing: {reference}")
    # The command line: OUT/split is no arm; the output is the table.
    run = subprocess.run([sys.executable, str(root / "scripts" / "restart_twins.py"), str(out)],
                         capture_output=True, text=True)
    if run.returncode != 0 or "| split |" in run.stdout or "| online |" not in run.stdout:
        fail(f"restart_twins.py OUT: the arms uninterrupted and online, not split: {run.stdout}{run.stderr}")
    (out / "online" / "restarts.jsonl").write_text('{"restart": {"epoch": 4}}\n')
    run = subprocess.run([sys.executable, str(root / "scripts" / "restart_twins.py"), str(out)],
                         capture_output=True, text=True)
    if run.returncode == 0 or "restarted at epoch 4" not in run.stderr:
        fail(f"restart_twins.py OUT compared an arm restarted at 4 with twins split at 3: {run.stdout}{run.stderr}")
    (out / "online" / "restarts.jsonl").write_text('{"restart": {"epoch": 1}}\n{"restart": {"epoch": 3}}\n')

    # Refused by name, not compared.
    short = arm(out, "half", [0.5], [0.5], first=3)
    refused(lambda: rt.table({"uninterrupted": ref, "half": rt.arm_counts(short, 3)}, 3),
            "different numbers of epochs", "arms of 2 and 1 epochs from the split")
    refused(lambda: rt.table({"online": rt.arm_counts(out / "online", 3)}, 3),
            "uninterrupted", "a table without the uninterrupted arm")
    gap = arm(out, "full", [0.5, 0.5], [0.5, 0.5], first=3)
    (gap / "metrics.csv").write_text("epoch,success_rate,train_success_rate\n3,0.5,0.5\n5,0.5,0.5\n")
    refused(lambda: rt.arm_counts(gap, 3), "not consecutive", "epochs 3 and 5 pooled as consecutive")
    (gap / "metrics.csv").write_text("epoch,success_rate,train_success_rate\n3,0.5,0.5\n4,0.5,\n")
    refused(lambda: rt.arm_counts(gap, 3), "train_success_rate", "an epoch without its training success")
    # A restarted arm that split elsewhere than EPOCH0 (a source whose metrics.csv lagged its checkpoint).
    refused(lambda: rt.check_split(out / "online", 2), "not at the twins' EPOCH0 2", "an arm restarted at 3, EPOCH0 2")
    (out / "twins.env").write_text("RUN=/nowhere\n")
    run = subprocess.run([sys.executable, str(root / "scripts" / "restart_twins.py"), str(out)],
                         capture_output=True, text=True)
    if run.returncode == 0 or "EPOCH0" not in run.stderr:
        fail(f"twins.env without EPOCH0 should be refused naming it: {run.returncode} {run.stderr}")

print("restart twins: ok")
