#!/usr/bin/env python3
"""Regression test: `scripts/compare_arms.py`'s tables of where the test
episodes ended and of the learning curves count what they say.

Guards the table added on 2026-12-02 to set the lite arms' final tilt beside
their contacts (does the arm that keeps more sensors in touch end more
tilted?). On made-up records whose answer is known: the median is over
every episode and pooled seeds pool their episodes, a dropped episode close
to its goal is not within, the mean contact is the mean, the difference is
the first arm minus the other, and runs trained to different thresholds get
no share. Runs in a second (CI's `compare-arms` stage).
"""

import json
import subprocess
import sys
import tempfile
from pathlib import Path

root = Path(__file__).resolve().parent.parent


def fail(msg):
    print(f"FAIL: {msg}", file=sys.stderr)
    sys.exit(1)


def run_dir(base, name, angles, dropped=(), contacts=100, threshold=0.1):
    """A run's records: test episode i ends `angles[i]` rad from its goal (in yaw and tilt alike), dropped where i
    is in `dropped`; success is within 0.4 rad and held."""
    d = base / name
    d.mkdir()
    records = [{"dropped": i in dropped, "total_contacts": contacts,
                "orientation": {"full_angle": a, "yaw_error": a, "tilt": a}} for i, a in enumerate(angles)]
    wins = sum(1 for i, a in enumerate(angles) if a < 0.4 and i not in dropped)
    (d / "eval.json").write_text(json.dumps({
        "engine": "mujoco", "goal_distance": "full", "records": records,
        "outcomes": {"successes": wins, "episodes": len(angles), "drop": len(dropped)}}))
    (d / "config.toml").write_text(f"[env]\nsuccess_threshold = {threshold}\n")
    return d


def compare(*arms):
    """compare_arms.py's output over `arms`, and the rows of its table of where the episodes ended by their
    first two cells (`A/`a_s0``, `**A, 2 seeds pooled**/`)."""
    out = subprocess.run([sys.executable, str(root / "scripts/compare_arms.py"), *arms],
                         capture_output=True, text=True)
    if out.returncode != 0:
        fail(f"compare_arms.py failed: {out.stderr}")
    table = out.stdout.split("Where the test episodes ended", 1)[1] if "Where the test episodes ended" in out.stdout else ""
    rows = {}
    for line in table.splitlines():
        cells = [c.strip() for c in line.split("|")[1:-1]]
        if len(cells) == 5 and cells[0] not in ("Arm", "---"):
            rows[f"{cells[0]}/{cells[1]}"] = cells
    return out.stdout, rows


with tempfile.TemporaryDirectory() as tmp:
    base = Path(tmp)
    # Arm A: 4 episodes a seed; 3 of 8 within 0.1 rad (one more close one dropped).
    a0 = run_dir(base, "a_s0", [0.05, 0.09, 0.2, 0.3], dropped={1}, contacts=100)
    a1 = run_dir(base, "a_s1", [0.01, 0.08, 0.5, 0.7], contacts=300)
    # Arm B: none within.
    b0 = run_dir(base, "b_s0", [0.2, 0.2, 0.3, 0.9], contacts=50)
    text, rows = compare(f"A={a0},{a1}", f"B={b0}")
    pooled = rows.get("**A, 2 seeds pooled**/")
    if pooled is None:
        fail(f"no pooled row of A in the table of where the episodes ended:\n{text}")
    # Pooled angles 0.01 0.05 0.08 0.09 0.2 0.3 0.5 0.7: the median is 0.145.
    if pooled[2] != "0.145 (yaw 0.145, tilt 0.145)":
        fail(f"the pooled median is not over every episode of both seeds: {pooled}")
    if not pooled[3].endswith("(3/8)"):
        fail(f"the dropped close episode counted, or the seeds were not pooled: {pooled}")
    if pooled[4] != "200":
        fail(f"the mean contact is not the mean of the episodes': {pooled}")
    if not rows["A/`a_s0`"][3].endswith("(1/4)"):
        fail(f"seed 0 of A: one episode within 0.1 rad not dropped: {rows['A/`a_s0`']}")
    diff = next((line for line in text.splitlines() if line.startswith("- A minus B: within 0.1 rad")), None)
    if diff is None or "+38 pts" not in diff:
        fail(f"the difference is not A's 3/8 minus B's 0/4: {diff}")
    # Runs trained to different thresholds: no share, no difference.
    c0 = run_dir(base, "c_s0", [0.05, 0.2], threshold=0.2)
    text, rows = compare(f"A={a0}", f"C={c0}")
    if "minus C: within" in text or rows["C/`c_s0`"][3] != "—" or rows["A/`a_s0`"][3] != "—":
        fail(f"runs of different thresholds got a share:\n{text}")

    # The learning curves. Two seeds of arm D over 12 epochs of 10 episodes: seed 0 reaches 5/10 at epoch 3 and
    # stays there; seed 1 gets 1/10 every epoch. Arm E: nothing.
    def with_curve(d, successes, episodes=10):
        (d / "config.toml").write_text(f"[env]\nsuccess_threshold = 0.1\n\n[trainer]\neval_episodes = {episodes}\n")
        lines = ["epoch,goal_distance,success_rate"] + [f"{e},full,{k / episodes}" for e, k in enumerate(successes)]
        (d / "metrics.csv").write_text("\n".join(lines) + "\n")
        return d
    d0 = with_curve(run_dir(base, "d_s0", [0.1]), [0, 0, 2, 5] + [5] * 8)
    d1 = with_curve(run_dir(base, "d_s1", [0.1]), [1] * 12)
    e0 = with_curve(run_dir(base, "e_s0", [0.1]), [0] * 12)
    text = subprocess.run([sys.executable, str(root / "scripts/compare_arms.py"), f"D={d0},{d1}", f"E={e0}"],
                          capture_output=True, text=True).stdout
    curves = {}
    for line in text.split("Learning curves", 1)[-1].splitlines():
        cells = [c.strip() for c in line.split("|")[1:-1]]
        if len(cells) == 6 and cells[0] not in ("Arm", "---"):
            curves[f"{cells[0]}/{cells[1]}"] = cells
    row = curves.get("D/`d_s0`")
    if row is None or not row[3].endswith("(47/120)") or not row[4].endswith("(47/100)") or row[5] != "3":
        fail(f"seed 0 of D: 47 of 120 episodes, 47 of the last 100 (epochs 2-11), 50 % first at epoch 3: {row}\n{text}")
    row = curves.get("**D, 2 seeds pooled**/")
    if row is None or not row[3].endswith("(59/240)") or not row[4].endswith("(57/200)") or row[5] != "3, never":
        fail(f"D's seeds pooled: 59 of 240, 57 of the last 200, first epochs 3 and never: {row}\n{text}")
    diff = next((line for line in text.splitlines() if line.startswith("- D minus E: last 10 epochs")), None)
    if diff is None or "+28 pts" not in diff:
        fail(f"the difference over the last 10 epochs is not D's 57/200 minus E's 0/100: {diff}")
    # Epochs out of order or repeated (a restart's lost rows kept): refused, not read.
    (d1 / "metrics.csv").write_text("epoch,goal_distance,success_rate\n0,full,0\n2,full,0\n")
    out = subprocess.run([sys.executable, str(root / "scripts/compare_arms.py"), f"D={d1}"], capture_output=True, text=True)
    if out.returncode == 0 or "not 0, 1, 2" not in out.stderr:
        fail(f"a metrics.csv without epoch 1 was read: {out.stderr}")
    (d1 / "metrics.csv").write_text("epoch,goal_distance,success_rate\n0,full,0\n1,full,0\n1,full,0.5\n")
    out = subprocess.run([sys.executable, str(root / "scripts/compare_arms.py"), f"D={d1}"], capture_output=True, text=True)
    if out.returncode == 0 or "not 0, 1, 2" not in out.stderr:
        fail(f"a metrics.csv with epoch 1 twice was read: {out.stderr}")
print("ok: compare_arms.py's tables of where the episodes ended and of the learning curves")
