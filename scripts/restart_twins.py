#!/usr/bin/env python3
"""What a late restart from a rescue point costs, against the same run uninterrupted.

The paper-budget pair restarted from rescue points (issue 53) and its restart
table (scripts/long_runs_restarts.py) can only set a restart's epochs against
the run's own epochs before it. `scripts/restart_twins.sh` trains twins from
one checkpoint instead: `uninterrupted` resumes a copy of the checkpoint, and
each other arm restarts from a rescue point written from it (`fmsr rescue
--keep KEEP`, `fmsr train --rescue --refill R`), all to the same epoch. This
script compares them:

    restart_twins.py OUT
        prints the table of OUT/<arm>/ (each a run directory, beside
        OUT/twins.env: EPOCH0, the epochs trained when the twins split; a
        directory without metrics.csv, as OUT/split/, is no arm)

For each arm, over the epochs from EPOCH0 on: the epochs' deterministic eval
episodes (`success_rate`, `trainer.eval_episodes` an epoch, at the training
threshold) and exploring training rollouts (`train_success_rate`,
`trainer.cycles` x `trainer.episodes_per_cycle` an epoch), pooled, and the
final policy's test-set evaluation (`eval.json`, its `outcomes`) where the
arm has one; each restarted arm's difference from `uninterrupted` with
Newcombe's interval. That interval takes each arm's pooled episodes for one
binomial sample; they are not (one policy an epoch, and one twin per arm:
how far two uninterrupted twins would drift apart by chance is not
measured here), so a difference inside it is no cost this measure sees and
one outside it is a question, not a verdict on the rescue point.
"""

import argparse
import csv
import json
import sys
from pathlib import Path

from long_runs_final import newcombe, pct, pts, wilson
from long_runs_restarts import episodes_per_epoch, successes

REFERENCE = "uninterrupted"


def epoch0(out):
    """EPOCH0 of OUT/twins.env, the epochs trained when the twins split."""
    for line in (out / "twins.env").read_text().splitlines():
        key, eq, value = line.partition("=")
        if eq and key.strip() == "EPOCH0":
            return int(value.strip())
    raise ValueError(f"{out / 'twins.env'} has no EPOCH0")


def arm_counts(run, start):
    """An arm's pooled (eval, train) (successes, episodes) over its epochs from `start`, the epochs it has trained
    there, and its test evaluation's (successes, episodes) or None."""
    per_epoch = episodes_per_epoch(run / "config.toml")
    if per_epoch is None:
        raise ValueError(f"{run / 'config.toml'} does not say trainer.eval_episodes, cycles and episodes_per_cycle")
    with open(run / "metrics.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    pooled, epochs = [], None
    for column, n in zip(("success_rate", "train_success_rate"), per_epoch):
        counts = {e: k for e, k in successes(rows, column, n).items() if e >= start}
        if epochs is not None and sorted(counts) != epochs:
            raise ValueError(f"{run / 'metrics.csv'}: {column} is not in every epoch's row")
        epochs = sorted(counts)
        if epochs != list(range(start, start + len(epochs))):
            raise ValueError(f"{run / 'metrics.csv'}: the epochs from {start} are not consecutive: {epochs}")
        pooled.append((sum(counts.values()), n * len(counts)))
    test = None
    if (run / "eval.json").exists():
        o = json.loads((run / "eval.json").read_text())["outcomes"]
        test = (o["successes"], o["episodes"])
    return pooled[0], pooled[1], len(epochs), test


def check_split(run, start):
    """A restarted arm's last restart (its restarts.jsonl) must be at `start`: else EPOCH0 is not the epoch the
    twins split at (a source whose metrics.csv lagged its checkpoint), and the pooled epochs would be wrong."""
    path = run / "restarts.jsonl"
    lines = [x for x in path.read_text().splitlines() if x.strip()] if path.exists() else []
    epoch = json.loads(lines[-1]).get("restart", {}).get("epoch") if lines else None
    if epoch != start:
        raise ValueError(f"{path}: the arm restarted at epoch {epoch}, not at the twins' EPOCH0 {start}")


def cell(a, ref):
    """An arm's rate (Wilson) and, beside the reference's, its difference (Newcombe)."""
    if a is None or a[1] == 0:
        return "n/a | n/a"
    w = wilson(*a)
    if ref is None or ref[1] == 0:
        return f"{pct(w)} | reference"
    return f"{pct(w)} | {pts(newcombe(w, wilson(*ref)))}"


def table(arms, start):
    """The markdown lines comparing `arms` ({name: arm_counts}) with the `uninterrupted` one, from epoch `start`."""
    if REFERENCE not in arms:
        raise ValueError(f"no `{REFERENCE}` arm to compare the restarts with")
    trained = {name: a[2] for name, a in arms.items()}
    if len(set(trained.values())) != 1:
        raise ValueError(f"the arms trained different numbers of epochs from {start}: {trained}")
    ref = arms[REFERENCE]
    lines = [f"Twins from the checkpoint after {start} epochs, {ref[2]} epochs each "
             f"(epochs {start}-{start + ref[2] - 1}); each restarted arm against `{REFERENCE}`, with Newcombe's "
             "interval, which takes an arm's pooled episodes for one binomial sample (one policy an epoch, one twin "
             "per arm: how far two uninterrupted twins drift apart by chance is not measured):", "",
             "| Arm | Eval (pooled) | Eval difference | Train (pooled) | Train difference "
             "| Test (final policy) | Test difference |", "|---|---|---|---|---|---|---|"]
    for name in [REFERENCE] + sorted(n for n in arms if n != REFERENCE):
        a = arms[name]
        is_ref = name == REFERENCE
        cells = [cell(a[0], None if is_ref else ref[0]), cell(a[1], None if is_ref else ref[1]),
                 cell(a[3], None if is_ref else ref[3])]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return lines


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("out", type=Path, help="the twins' directory (scripts/restart_twins.sh OUT)")
    args = p.parse_args()
    try:
        start = epoch0(args.out)
        dirs = [d for d in sorted(args.out.iterdir()) if d.is_dir() and (d / "metrics.csv").exists()]
        for d in dirs:
            if d.name != REFERENCE:
                check_split(d, start)
        arms = {d.name: arm_counts(d, start) for d in dirs}
        print("\n".join(table(arms, start)))
    except (OSError, ValueError, KeyError) as e:
        sys.exit(f"restart_twins: {e}")


if __name__ == "__main__":
    main()
