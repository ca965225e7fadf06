#!/usr/bin/env python3
"""Regression test: the long runs' restart table measures what it says.

Guards the table `scripts/long_runs.sh record` writes of what each restart
from a rescue point cost (2026-12-01: the pair was restored from its rescue
points a third time, at epochs 270 and 251, and the earlier sessions' notes
compared epochs before and after each restart by hand). On made-up metrics
whose answer is known: a restart after which success falls by 20 points on a
flat run is below the spread of the boundaries without one; the same run
without that fall is within it; a boundary whose windows hold another restart
is no reference; a restart without its full windows gives n/a, not a number
from fewer epochs; rates are read back as counts of the epoch's episodes.
Runs in a second (CI's `long-runs-restarts` stage).
"""

import sys
from pathlib import Path

root = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(root / "scripts"))
import long_runs_restarts as lr  # noqa: E402


def fail(msg):
    print(f"FAIL: {msg}", file=sys.stderr)
    sys.exit(1)


def metrics(rates, train=None):
    """metrics.csv rows: epoch i with eval success `rates[i]` and training success `train[i]` (else the same)."""
    train = rates if train is None else train
    return [{"epoch": str(i), "success_rate": str(r), "train_success_rate": str(t)} for i, (r, t) in
            enumerate(zip(rates, train))]


# Rates are counts of the epoch's episodes: 0.34 of 50 is 17, a missing column is no epoch.
c = lr.successes([{"epoch": "0", "success_rate": "0.34"}, {"epoch": "1"}], "success_rate", 50)
if c != {0: 17}:
    fail(f"0.34 of 50 episodes should be 17 successes and a row without the column left out: {c}")

# A flat run at 50 % with a little noise, then 30 % for the ten epochs after a restart at epoch 60.
noise = [0.02 * ((i * 7) % 3 - 1) for i in range(120)]
flat = [0.5 + n for n in noise]
fallen = [r - 0.2 if 60 <= i < 70 else r for i, r in enumerate(flat)]
cost = lr.restart_cost(lr.successes(metrics(fallen), "success_rate", 50), 50, 60, [60])
if cost is None or abs(cost["difference"][0] + 0.2) > 0.01:
    fail(f"a fall of 20 points after the restart should read -0.20: {cost}")
if lr.verdict(cost) != "below the spread":
    fail(f"a fall of 20 points on a flat run should lie below the spread without a restart: {cost}")
# The boundaries whose windows straddle the fall (epochs 51-79) differ by up to 20 points too, but the spread's
# lowest must come from them, not from the restart's own boundary: it is above -0.2.
if not cost["spread"][0] > -0.2 + 1e-9:
    fail(f"the restart's own boundary must not be in its reference: {cost['spread']}")
same = lr.restart_cost(lr.successes(metrics(flat), "success_rate", 50), 50, 60, [60])
if same is None or lr.verdict(same) != "within the spread":
    fail(f"a restart after which nothing changed should be within the spread: {same}")
# 101 boundaries in 10..110 are within 50 of 60; the restart's own and those whose windows hold it (51-69) are out.
if same["spread"][2] != 101 - 19:
    fail(f"the reference should count the 82 boundaries without the restart in their windows: {same['spread']}")

# Another restart at 90 takes the boundaries 81-99 out of the reference of the one at 60.
two = lr.restart_cost(lr.successes(metrics(flat), "success_rate", 50), 50, 60, [60, 90])
if two["spread"][2] != 101 - 19 - 19:
    fail(f"boundaries whose windows hold the restart at 90 should be no reference for the one at 60: {two['spread']}")

# Without its ten epochs on both sides, no number.
short = lr.successes(metrics(flat[:65]), "success_rate", 50)
if lr.restart_cost(short, 50, 60, [60]) is not None:
    fail("a restart with 5 of its 10 epochs after it trained should give no number")
if lr.restart_cost(lr.successes(metrics(flat), "success_rate", 50), 50, 4, [4]) is not None:
    fail("a restart at epoch 4 has no 10 epochs before it and should give no number")

# The table: a row per restart, eval and training each measured; n/a where the windows are not trained.
run = {"label": "Dense", "metrics": metrics(fallen, flat), "per_epoch": (50, 200),
       "restarts": [{"restart": {"epoch": 60}}, {"restart": {"epoch": 115}}]}
lines = lr.table([run])
rows = [line for line in lines if line.startswith("| Dense |")]
if len(rows) != 2:
    fail(f"one row per restart expected: {lines}")
cells = [c.strip() for c in rows[0].strip("|").split("|")]
if cells[1] != "60" or "-20 pts" not in cells[4] or "below the spread" not in cells[5] or "within the spread" not in cells[9]:
    fail(f"the restart at 60 should fall 20 points in eval (below the spread) and not in training: {cells}")
if "n/a" not in rows[1]:
    fail(f"the restart at 115 has 5 epochs after it and should read n/a: {rows[1]}")
# Restarts at one epoch (the home lost again before a newer rescue point) read the same records: one row, counted.
again = lr.table([{**run, "restarts": run["restarts"] + [{"restart": {"epoch": 60}}, {"restart": {"epoch": 60}}]}])
again_rows = [line for line in again if line.startswith("| Dense |")]
if len(again_rows) != 2 or "| 60 (3 times) |" not in again_rows[0] or again_rows[0].split("|")[3:] != rows[0].split("|")[3:]:
    fail(f"three restarts at epoch 60 should read as one row counting them, with the same numbers: {again_rows}")
if lr.table([{**run, "restarts": []}]) != []:
    fail("runs that never restarted should give no table")
print("ok: the restart table sets the 10 epochs after each restart against the 10 before and the spread without one")
