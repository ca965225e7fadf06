#!/usr/bin/env python3
"""Regression test: the long runs' precision table counts what it says.

Guards the table `scripts/long_runs.sh record` writes beside the snapshots'
success (2026-11-29): at snapshot 149 both runs of the paper-budget pair were
at 98-100 % by the success rule at 0.4 rad, while their test episodes ended
0.115 and 0.077 rad from the goal (median). The table gives the median final
full angle and the episodes that ended within 0.1 rad without a drop. This
checks, on made-up records whose answer is known: a dropped episode close to
its goal does not count, the median is the median, evaluations written before
the full angle was recorded give no row, and the difference is the first run
minus the second; and `finish`'s table of the same for the final evaluations.
Runs in a second (CI's `long-runs-precision` stage).
"""

import sys
import tempfile
from pathlib import Path

root = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(root / "scripts"))
import long_runs_final as fin  # noqa: E402
import long_runs_record as rec  # noqa: E402


def fail(msg):
    print(f"FAIL: {msg}", file=sys.stderr)
    sys.exit(1)


def evaluation(angles, dropped=()):
    """An evaluation whose episode i ended `angles[i]` rad from its goal, dropped where i is in `dropped`."""
    return {"success_rate": 0.0, "episodes": len(angles), "records": [
        {"dropped": i in dropped, "orientation": {"full_angle": a, "yaw_error": a, "tilt": 0.0}}
        for i, a in enumerate(angles)]}


# Five episodes: three end within 0.1 rad, one of those three was dropped, and
# one ends exactly at 0.1 (not within).
e = rec.final_angles(evaluation([0.05, 0.09, 0.08, 0.1, 0.7], dropped={2}), 0.1)
if e["precise"][0] != 2 / 5:
    fail(f"within 0.1 rad without a drop should be 2 of 5, got {e['precise'][0]}")
if abs(e["median_angle"] - 0.09) > 1e-12:
    fail(f"median final angle should be 0.09, got {e['median_angle']}")
lo, hi = e["precise"][1], e["precise"][2]
if not (0 < lo < 0.4 < hi < 1):
    fail(f"the Wilson interval of 2 of 5 should hold 0.4 strictly inside (0, 1), got [{lo}, {hi}]")

# Evaluations from before the full angle was recorded (no `orientation`) give none.
old = {"success_rate": 0.0, "episodes": 2, "records": [{"dropped": False}, {"dropped": False}]}
if rec.final_angles(old, 0.1) != {"median_angle": None, "median_yaw": None, "median_tilt": None, "precise": None,
                                  "within": 0.1}:
    fail(f"an evaluation without the full angle should give no precision, got {rec.final_angles(old, 0.1)}")
# The same episodes counted at another training threshold: within 0.06 rad only the first.
if rec.final_angles(evaluation([0.05, 0.09, 0.08, 0.1, 0.7], dropped={2}), 0.06)["precise"][0] != 1 / 5:
    fail("within 0.06 rad without a drop should be 1 of 5")
# Under gym's distance (the paper's stack) an episode is within by gym's own distance: the second one ends
# 0.05 rad from the goal's orientation but at its double cover, 2 pi - 0.05 from it by gym, and is not within.
gym = evaluation([0.05, 0.05, 0.7])
gym["goal_distance"] = "gym"
for r, d in zip(gym["records"], [0.05, 2 * 3.141592653589793 - 0.05, 0.7]):
    r["final_error"] = d
if rec.final_angles(gym, 0.1)["precise"][0] != 1 / 3:
    fail("under gym's distance an episode at the goal's double cover was counted within 0.1 rad")
# Without a threshold (no config.toml, no `env.success_threshold`) there is no share, never one at a guessed value.
if rec.final_angles(evaluation([0.05]), None)["precise"] is not None:
    fail("an evaluation without a training threshold should give no share")

# The threshold comes from the run's config.toml, as the binary writes it (the f32 of 0.1).
with tempfile.TemporaryDirectory() as tmp:
    config = Path(tmp) / "config.toml"
    config.write_text('method = "dense"\n\n[env]\nepisode_len = 50\nsuccess_threshold = 0.10000000149011612\n')
    if fin.training_threshold(config) != 0.1:
        fail(f"the threshold of a config with success_threshold = 0.1 (f32) should read 0.1, got "
             f"{fin.training_threshold(config)}")
    config.write_text('method = "dense"\n\n[env]\nepisode_len = 50\n')
    if fin.training_threshold(config) is not None:
        fail("a config without env.success_threshold should give no threshold")
    if fin.training_threshold(Path(tmp) / "missing.toml") is not None:
        fail("a missing config should give no threshold")


def run(label, snapshots, within=0.1):
    return {"label": label, "within": within,
            "snapshots": [(k, {"test": t, "validation": None}) for k, t in snapshots.items()]}


def test(angles, within=0.1):
    e = evaluation(angles)
    return {**e, **rec.final_angles(e, within)}


a = run("Dense+FMSR+IS", {49: test([0.05] * 2 + [0.3] * 8), 99: test([0.05] * 10), 149: {"precise": None}})
b = run("Dense", {49: test([0.05] * 6 + [0.3] * 4), 99: test([0.05] * 10), 149: test([0.05] * 10)})
lines = rec.precision_table([a, b], [49, 99, 149])
rows = [line for line in lines if line.startswith("| ") and not line.startswith("| Snapshot")]
if [r.split(" |")[0] for r in rows] != ["| 49", "| 99"]:
    fail(f"rows should be snapshots 49 and 99 (149 has no full angle in one run), got {rows}")
if "20 % [" not in rows[0] or "60 % [" not in rows[0] or "| -40 pts [" not in rows[0]:
    fail(f"snapshot 49 should read 20 % against 60 %, difference -40 pts: {rows[0]}")
if any("{" in line for line in lines):
    fail(f"the table's text has an unformatted field: {lines}")
if rec.precision_table([a, b], [149]) != []:
    fail("a table without a row should not be written")
# `finish`'s table, the final evaluations: 3 of 4 against 1 of 4 within 0.1 rad (one close episode dropped).
rows = fin.precision_rows(evaluation([0.01, 0.02, 0.03, 0.5]), evaluation([0.01, 0.02, 0.3, 0.5], dropped={1}),
                          ("Dense+FMSR+IS", "Dense"), (0.1, 0.1))
if len(rows) != 5 or "| Dense+FMSR+IS | 0.025 (yaw 0.025, tilt 0.000) | 75 % [" not in rows[2] \
        or "| Dense | 0.160 (yaw 0.160, tilt 0.000) | 25 % [" not in rows[3] \
        or "| +50 pts [" not in rows[4]:
    fail(f"finish's table should read 75 % (median 0.025) against 25 % (median 0.160), +50 pts: {rows}")
if fin.precision_rows(old, old, ("a", "b"), (0.1, 0.1)) != []:
    fail("finish's table should be left out for evaluations without the full angle")

# Runs trained to different thresholds: each share at its own, and no difference between them.
a = run("Dense+FMSR+IS", {49: test([0.05] * 10, 0.1)}, 0.1)
b = run("Dense", {49: test([0.05] * 5 + [0.15] * 5, 0.2)}, 0.2)
lines = rec.precision_table([a, b], [49])
row = [line for line in lines if line.startswith("| 49")]
if not row or "100 % [" not in row[0] or not row[0].endswith(" n/a |") or "pts" in row[0]:
    fail(f"runs at thresholds 0.1 and 0.2 should read 100 % each with no difference: {row}")
if not any("within 0.1 rad" in line and "within 0.2 rad" in line for line in lines):
    fail(f"the header should name each run's own threshold: {lines}")
rows = fin.precision_rows(evaluation([0.05, 0.5]), evaluation([0.15, 0.5]), ("a", "b"), (0.1, 0.2))
if not rows or "50 % [" not in rows[3] or "pts" in rows[4]:
    fail(f"finish's table at thresholds 0.1 and 0.2 should count 0.15 within 0.2 and take no difference: {rows}")
# `finish`'s section: the test set's table, then the same over Table II's trials where both runs have them.
fa = {"label": "Dense+FMSR+IS", "within": 0.1, "finals": {
    "test-mujoco": evaluation([0.01, 0.5]), "trials-mujoco": evaluation([0.01, 0.5, 0.02, 0.03])}}
fb = {"label": "Dense", "within": 0.1, "finals": {
    "test-mujoco": evaluation([0.5, 0.5]), "trials-mujoco": evaluation([0.5, 0.5, 0.02, 0.6])}}
lines = fin.precision_blocks(fa, fb, "mujoco", "MuJoCo")
titles = [line for line in lines if line.startswith("**")]
if len(titles) != 2 or "test episodes ended" not in titles[0] or "Table II's 4 trials, MuJoCo" not in titles[1] \
        or "the 2 above among them" not in titles[1]:
    fail(f"finish's section should give the test set's table, then the 4 trials': {titles}")
trials = lines[lines.index(titles[1]):]
if not any("| Dense+FMSR+IS |" in r and "75 % [" in r for r in trials) \
        or not any("| Dense |" in r and "25 % [" in r for r in trials) or not any("+50 pts [" in r for r in trials):
    fail(f"the trials' table should read 3 of 4 against 1 of 4 within 0.1 rad, +50 pts: {trials}")
del fb["finals"]["trials-mujoco"]
if sum(1 for line in fin.precision_blocks(fa, fb, "mujoco", "MuJoCo") if line.startswith("**")) != 1:
    fail("without both runs' trials, only the test set's table")
print("ok: the precision table counts episodes within each run's training threshold without a drop, per snapshot")
