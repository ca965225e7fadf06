#!/usr/bin/env python3
"""Regression test: `scripts/long_runs.sh record` rewrites a rescue point about once a day of training, or once a
day by the clock when the run has trained an hour or more since it.

Every rescue point the keeper writes into pretrained/ stays in git's history,
so `record` (re)writes a run's only while the run has epochs left to train,
and only when pretrained/ has none of this run yet or the one there is a day
of training old (the `seconds` of the metrics.csv epochs after its EPOCH add
up to 86400 or more, or it was written 20 h or more ago and an hour of
training follows it: the home has been lost about once a day, long before a
day of training); best_so_far.fmsr follows it. This checks the decision
(scripts/long_runs_rescue.py) on a table of made-up runs whose answer is
known, its command line on rescue points on disk (none, this run's, an earlier
run's of the same name), and the keeper's own `rescue_and_best` on a scratch
home with a stand-in for `fmsr rescue`: it writes, keeps, then rewrites, and
copies best_so_far.fmsr only with a rewritten rescue point or the first time.
Runs in a few seconds; no build needed.
"""

import json
import os
import subprocess
import sys
import tempfile
from datetime import timedelta
from pathlib import Path

root = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(root / "scripts"))
import long_runs_rescue as lr  # noqa: E402

HOUR = 3600


def fail(msg):
    print(f"FAIL: {msg}", file=sys.stderr)
    sys.exit(1)


def rows(seconds):
    """metrics.csv rows: epoch i (from 0) took seconds[i]."""
    return [{"epoch": str(i), "seconds": str(s)} for i, s in enumerate(seconds)]


# 100 epochs of an hour each.
hourly = rows([HOUR] * 100)
CASES = [
    # (what, rows, rescue EPOCH or None, finished, write?)
    ("no rescue point yet", hourly, None, False, True),
    ("no rescue point yet, after one epoch", rows([HOUR]), None, False, True),
    ("23 h since the rescue point", hourly, 77, False, False),
    ("24 h since the rescue point, the threshold itself", hourly, 76, False, True),
    ("25 h since the rescue point", hourly, 75, False, True),
    ("the rescue point is of the last epoch", hourly, 100, False, False),
    ("a rescue point ahead of the run's epochs (not this run's)", hourly, 120, False, True),
    ("a finished run with a rescue point 25 h old", hourly, 75, True, False),
    ("a finished run without a rescue point", hourly, None, True, False),
    # Epochs of different lengths: 10 of 2 h and 5 of 0.5 h after EPOCH 5 are 22.5 h, one more 2 h epoch 24.5 h.
    ("22.5 h in uneven epochs", rows([HOUR] * 5 + [2 * HOUR] * 10 + [HOUR / 2] * 5), 5, False, False),
    ("24.5 h in uneven epochs", rows([HOUR] * 5 + [2 * HOUR] * 10 + [HOUR / 2] * 5 + [2 * HOUR]), 5, False, True),
]
for what, rs, epoch, finished, want in CASES:
    write, why = lr.due(rs, epoch, 86400, finished)
    if write != want:
        fail(f"{what}: {'write' if want else 'skip'} expected, got {'write' if write else 'skip'} ({why})")
    if "\n" in why or not why:
        fail(f"{what}: the reason should be one line: {why!r}")
if abs(lr.seconds_since(hourly, 75) - 25 * HOUR) > 1e-6:
    fail(f"25 epochs of an hour after EPOCH 75, got {lr.seconds_since(hourly, 75)} s")
# Another threshold: 2 h.
if lr.due(hourly, 98, 2 * HOUR)[0] is not True or lr.due(hourly, 99, 2 * HOUR)[0] is not False:
    fail("with a threshold of 2 h, a rescue point 2 h old is rewritten and one 1 h old is kept")

# The clock's day: a rescue point written 20 h or more ago is rewritten once the run trained an hour after it.
written = lr.parse_time("2026-12-03T10:35:01Z")
CLOCK = [
    # (what, rows, rescue EPOCH, hours since written or None, write?)
    ("written 3 days ago, 2 h of training since", hourly, 98, 72, True),
    ("written 3 days ago, 1 h of training since: the floor itself", hourly, 99, 72, True),
    ("written 3 days ago, no training since", hourly, 100, 72, False),
    ("written 20 h ago, 5 h of training since: the clock's threshold itself", hourly, 95, 20, True),
    ("written 19 h ago, 5 h of training since", hourly, 95, 19, False),
    ("written at an unknown time, 5 h of training since", hourly, 95, None, False),
    ("written an hour ago, 24 h of training since (the training's rule)", hourly, 76, 1, True),
]
for what, rs, epoch, ago, want in CLOCK:
    now = written + timedelta(hours=ago) if ago is not None else written
    write, why = lr.due(rs, epoch, 86400, False, written if ago is not None else None, now)
    if write != want:
        fail(f"{what}: {'write' if want else 'skip'} expected, got {'write' if write else 'skip'} ({why})")
    if "\n" in why or not why:
        fail(f"{what}: the reason should be one line: {why!r}")
if lr.due(hourly, 95, 86400, True, written, written + timedelta(hours=72))[0]:
    fail("a finished run is not rewritten, however old its rescue point")
for bad in ("x", "", "2026-12-03", "2026-12-03T10:35:01"):
    if lr.parse_time(bad) is not None:
        fail(f"{bad!r} is not a time with its zone: None expected")


def cli(metrics, rescue, *extra):
    out = subprocess.run([sys.executable, str(root / "scripts/long_runs_rescue.py"), "due", "--metrics", str(metrics),
                          "--rescue", str(rescue), *extra], capture_output=True, text=True, check=True).stdout
    if out.count("\n") != 1:
        fail(f"the command line should print one line: {out!r}")
    return out.split(":", 1)[0]


with tempfile.TemporaryDirectory() as tmp:
    tmp = Path(tmp)
    metrics = tmp / "metrics.csv"
    metrics.write_text("epoch,env_steps,seconds\n" + "".join(f"{i},{25000 * (i + 1)},3600\n" for i in range(30)))
    rescue = tmp / "rescue"
    if cli(metrics, rescue) != "write":
        fail("no rescue directory: write")
    rescue.mkdir()
    (rescue / "rescue.env").write_text("EPOCH=10\nKEEP=half\nWRITTEN=x\nSTARTED=2026-01-01T00:00:00Z\n")
    if cli(metrics, rescue) != "write":
        fail("a rescue.env without its rescue.fmsr is no rescue point: write")
    (rescue / "rescue.fmsr").write_text("x")
    if cli(metrics, rescue, "--started", "2026-01-01T00:00:00Z") != "skip":
        fail("20 h since this run's rescue point of epoch 10: skip")
    if cli(metrics, rescue, "--started", "2026-02-02T00:00:00Z") != "write":
        fail("a rescue point of an earlier run of the same name (another STARTED): write")
    if cli(metrics, rescue, "--every", str(20 * HOUR)) != "write":
        fail("20 h since the rescue point with a threshold of 20 h: write")
    if cli(metrics, rescue, "--every", str(20 * HOUR), "--finished") != "skip":
        fail("a run that has trained all its epochs: skip")
    # Written at a known time: 20 h by the clock and the hour of training after it rewrite it; 19 h do not.
    (rescue / "rescue.env").write_text("EPOCH=10\nKEEP=half\nWRITTEN=2026-12-03T10:35:01Z\nSTARTED=2026-01-01T00:00:00Z\n")
    if cli(metrics, rescue, "--now", "2026-12-04T06:35:01Z") != "write":
        fail("a rescue point written 20 h ago with 20 h of training since: write")
    if cli(metrics, rescue, "--now", "2026-12-04T05:35:01Z") != "skip":
        fail("a rescue point written 19 h ago with 20 h of training since (under a day): skip")
    bad = subprocess.run([sys.executable, str(root / "scripts/long_runs_rescue.py"), "due", "--metrics", str(metrics),
                          "--rescue", str(rescue), "--now", "yesterday"], capture_output=True, text=True)
    if bad.returncode == 0 or "--now" not in bad.stderr:
        fail(f"--now that is not a time: an error naming --now expected, got {bad.returncode} {bad.stderr!r}")
    # A rescue.env written before it named its run's STARTED is taken as this run's.
    (rescue / "rescue.env").write_text("EPOCH=10\nKEEP=online\nWRITTEN=x\n")
    if cli(metrics, rescue, "--started", "2026-02-02T00:00:00Z") != "skip":
        fail("a rescue.env without STARTED: by its EPOCH alone, skip")


# The keeper's own rescue_and_best, its functions sourced from scripts/long_runs.sh (all but the command dispatch),
# with a stand-in for `fmsr rescue` that writes a file and names the checkpoint's epoch as fmsr does.
def keeper(tmp, env_extra=None):
    script = (root / "scripts/long_runs.sh").read_text()
    functions = script[:script.index('case "${1:-}" in')]
    (tmp / "keeper_functions.sh").write_text(functions)
    # The keeper's settings are the test's own, whatever the caller's environment holds.
    env = {**{k: v for k, v in os.environ.items() if not k.startswith("FMSR_LONG_RUNS")}, "FMSR_LONG_RUNS": str(tmp / "home"), "FMSR_LONG_RUNS_RECORDS": str(tmp / "records"),
           "FMSR_LONG_RUNS_PRETRAINED": str(tmp / "pretrained"), **(env_extra or {})}
    # $0 is the keeper's own path, from which it finds the repository.
    out = subprocess.run(["bash", "-c", f'source "{tmp}/keeper_functions.sh"; fmsr="{tmp}/fmsr"; rescue_and_best',
                          str(root / "scripts/long_runs.sh")], capture_output=True, text=True, env=env)
    if out.returncode != 0:
        fail(f"rescue_and_best failed: {out.stdout}{out.stderr}")
    return out.stdout


def train(run, seconds):
    """The run trains epochs of `seconds` each (appended to its metrics.csv)."""
    csv_path = run / "run" / "metrics.csv"
    lines = csv_path.read_text().splitlines() if csv_path.exists() else ["epoch,env_steps,seconds"]
    for s in seconds:
        i = len(lines) - 1
        lines.append(f"{i},{25000 * (i + 1)},{s}")
    csv_path.write_text("\n".join(lines) + "\n")
    (run / "run" / "checkpoint.bin").write_text(str(len(lines) - 1))


def snapshot(tmp, run, k, success):
    """Snapshot k in the home and its validation evaluation in the records."""
    (run / "snapshots").mkdir(exist_ok=True)
    (run / "snapshots" / f"epoch-{k:03d}.fmsr").write_text(f"snapshot {k}")
    snaps = tmp / "records" / run.name / "snapshots"
    snaps.mkdir(parents=True, exist_ok=True)
    (snaps / f"epoch-{k:03d}.validation.json").write_text(
        json.dumps({"outcomes": {"successes": success, "episodes": 100}}))


with tempfile.TemporaryDirectory() as tmp:
    tmp = Path(tmp)
    (tmp / "fmsr").write_text('#!/usr/bin/env bash\n# fmsr rescue RUN --keep K --out FILE\n'
                              'n=$(cat "$2/checkpoint.bin"); echo "rescue $4 $n" > "$6"\n'
                              'echo "wrote a rescue point of epoch $n, keeping $4"\n')
    (tmp / "fmsr").chmod(0o755)
    run = tmp / "home" / "egg_dense"
    (run / "run").mkdir(parents=True)
    (run / "keeper.env").write_text("BIN=x\nEPOCHS=100\nCOMMIT=x\nSTARTED=2026-01-01T00:00:00Z\n")
    pre = tmp / "pretrained" / "egg_dense_paper_stack"
    train(run, [HOUR] * 10)
    snapshot(tmp, run, 0, 10)
    snapshot(tmp, run, 9, 20)
    out = keeper(tmp)
    env = lr.read_env(pre / "rescue" / "rescue.env")
    if env.get("EPOCH") != "10" or env.get("KEEP") != "half" or env.get("STARTED") != "2026-01-01T00:00:00Z":
        fail(f"the first record should write a rescue point of epoch 10 with --keep half, got {env}: {out}")
    if lr.read_env(pre / "best_so_far.env").get("EPOCH") != "9":
        fail(f"the first record should copy the best snapshot so far, epoch 9: {out}")
    # 20 h more, a better snapshot: the rescue point and best_so_far.fmsr are kept, and it says so.
    train(run, [HOUR] * 20)
    snapshot(tmp, run, 24, 30)
    before = (pre / "rescue" / "rescue.env").read_text()
    out = keeper(tmp)
    if (pre / "rescue" / "rescue.env").read_text() != before or "rescue point of epoch 10 kept: 20.0 h" not in out:
        fail(f"20 h after the rescue point it should be kept: {out}")
    if lr.read_env(pre / "best_so_far.env").get("EPOCH") != "9" or "keeps epoch 9 until" not in out:
        fail(f"best_so_far.fmsr should wait for the rescue point: {out}")
    # 5 h more (25 h since): both rewritten.
    train(run, [HOUR] * 5)
    out = keeper(tmp)
    if lr.read_env(pre / "rescue" / "rescue.env").get("EPOCH") != "35":
        fail(f"25 h after the rescue point it should be rewritten at epoch 35: {out}")
    if lr.read_env(pre / "best_so_far.env").get("EPOCH") != "24":
        fail(f"best_so_far.fmsr should follow the rewritten rescue point to epoch 24: {out}")
    # best_so_far.fmsr gone (as `finish` of an earlier campaign leaves none): copied at once.
    snapshot(tmp, run, 49, 40)
    (pre / "best_so_far.fmsr").unlink()
    out = keeper(tmp)
    if lr.read_env(pre / "best_so_far.env").get("EPOCH") != "49" or not (pre / "best_so_far.fmsr").exists():
        fail(f"without best_so_far.fmsr the best snapshot should be copied at once: {out}")
    # The run trains its last epochs, a day and more: no rescue point, it has ended.
    (run / "keeper.env").write_text("BIN=x\nEPOCHS=61\nCOMMIT=x\nSTARTED=2026-01-01T00:00:00Z\n")
    train(run, [HOUR] * 26)
    out = keeper(tmp)
    if lr.read_env(pre / "rescue" / "rescue.env").get("EPOCH") != "35" or "has trained all its epochs" not in out:
        fail(f"a run that has trained all its epochs gets no new rescue point: {out}")
    # The first campaign's suffix and its `online` rescue points, by the environment.
    out = keeper(tmp, {"FMSR_LONG_RUNS_SUFFIX": "_paper", "FMSR_LONG_RUNS_KEEP": "online"})
    if (tmp / "pretrained" / "egg_dense_paper" / "rescue").exists():
        fail(f"an ended run gets no rescue point under either suffix: {out}")
    (run / "keeper.env").write_text("BIN=x\nEPOCHS=100\nCOMMIT=x\nSTARTED=2026-01-01T00:00:00Z\n")
    out = keeper(tmp, {"FMSR_LONG_RUNS_SUFFIX": "_paper", "FMSR_LONG_RUNS_KEEP": "online"})
    env = lr.read_env(tmp / "pretrained" / "egg_dense_paper" / "rescue" / "rescue.env")
    if env.get("EPOCH") != "61" or env.get("KEEP") != "online":
        fail(f"FMSR_LONG_RUNS_SUFFIX=_paper should write pretrained/egg_dense_paper/rescue, online: {env}: {out}")

print("ok: record rewrites a rescue point while the run trains, when it has none, it is a day of training old, or a day old with an hour of training since")
