#!/usr/bin/env python3
"""The committed reproduction report is what the committed records give:
scripts/reproduction_report.py run again into a scratch directory writes
docs/report.md and every figure it links byte for byte; and its verdicts
follow the rule it states (checked on made-up intervals); a campaign in progress
keeps the snapshots of attempts lost with their homes (checked on made-up
records)."""
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "scripts"))
import reproduction_report as rr  # noqa: E402

assert rr.verdict((0.1, 0.3), +1) == "supported"
assert rr.verdict((-0.3, -0.1), +1) == "contradicted"
assert rr.verdict((-0.1, 0.3), +1) == "cannot tell"
assert rr.verdict((-0.7, -0.2), -1) == "supported"
assert rr.verdict((0.2, 0.7), -1) == "contradicted"
lo, hi = rr.wilson(100, 100)
assert round(100 * lo) == 96 and hi == 1.0
lo, hi = rr.newcombe(46, 100, 76, 100)
assert (round(100 * lo), round(100 * hi)) == (-42, -17), (lo, hi)

# A campaign in progress is read at its latest snapshot: 59 of 100 against 82, 2 within 0.1 rad against 4.
arm = lambda k, within: {"test": {"successes": k, "episodes": 100}, "within": within}
(_, test, word), (_, close, close_word) = rr.interim_claims({"Dense+FMSR+IS": arm(59, 2), "Dense": arm(82, 4)})
assert (test, word) == ("-23 pts [-35, -10]", "contradicted"), (test, word)
assert (close, close_word) == ("-2 pts [-8, +4]", "cannot tell"), (close, close_word)

# An interval's end that excludes zero never reads as zero: 95 of 100 against 100 of 100 ends at -0.3 pts, which
# whole points would print "-0" beside the verdict "contradicted".
(_, test, word), _ = rr.interim_claims({"Dense+FMSR+IS": arm(95, 1), "Dense": arm(100, 39)})
assert (test, word) == ("-5 pts [-11, -0.3]", "contradicted"), (test, word)
assert [rr.long_runs_final.points(x) for x in (0, 0.003, -0.00004, -0.11)] == ["+0", "+0.3", "-0.004", "-11"]

# An arm whose per-epoch success never reaches 50 % says so with its highest, never "epoch None".
rows = lambda *rates: [{"epoch": str(e), "success_rate": str(r)} for e, r in enumerate(rates)]
assert rr.reaching("Dense", rows(0.1, 0.6, 0.7), 0.5) == "Dense first reaches 50 % at epoch 1"
assert rr.reaching("Dense+FMSR+IS", rows(0.1, 0.24, 0.2), 0.5) == \
    "Dense+FMSR+IS never reaches 50 % in its 3 epochs (at most 0.24)"

# A campaign whose home was lost: the attempt set aside in lost-<time>/ keeps its snapshots in the report, and the
# opening table reads the snapshot furthest in training, the lost attempt's until this one passes it.
import json  # noqa: E402


def run_dir(d, epochs, snaps):
    """A made-up arm's run directory: `epochs` rows of metrics.csv, snapshots {epoch: successes of 100}."""
    (d / "snapshots").mkdir(parents=True)
    (d / "metrics.csv").write_text("epoch,seconds\n" + "".join(f"{i},1\n" for i in range(epochs)))
    for k, won in snaps.items():
        test = {"outcomes": {"successes": won, "episodes": 100, "drop": 0}, "stability": {"total_contacts": 0},
                "records": [{"final_error": 0.05 if i < won else 1.0, "dropped": False} for i in range(100)]}
        (d / "snapshots" / f"epoch-{k:03d}.test.json").write_text(json.dumps(test))
        (d / "snapshots" / f"epoch-{k:03d}.validation.json").write_text(json.dumps({"outcomes": test["outcomes"]}))


with tempfile.TemporaryDirectory() as tmp:
    records = Path(tmp)
    for label, run in rr.RUNS.items():
        d = records / run
        dense = label == "Dense"
        run_dir(d, 30, {9: 20 if dense else 10, 24: 60 if dense else 40})
        (d / "config.toml").write_text("[env]\nsuccess_threshold = 0.1\n")
        (d / "keeper.env").write_text("EPOCHS=400\n")
        # The two arms' homes went at slightly different times the same day; they pair in order.
        run_dir(d / ("lost-20261206T060139Z" if dense else "lost-20261206T061024Z"), 79 if dense else 78,
                {9: 20, 24: 70, 49: 99 if dense else 82})
    progress = rr.interim(records)
    assert progress["epochs"] == 30 and [s["epoch"] for s in progress["snapshots"]] == [9, 24], progress
    (lost,) = progress["attempts"]
    assert (lost["lost"], lost["epochs"], [s["epoch"] for s in lost["snapshots"]]) == ("2026-12-06", 78, [9, 24, 49])
    last, of = rr.latest(progress)
    assert last["epoch"] == 49 and of is lost, (last["epoch"], of)
    assert rr.interim_claims(last)[0][1:] == ("-17 pts [-26, -9]", "contradicted"), rr.interim_claims(last)
    section = rr.interim_section("paper_stack", "the paper's stack", progress)
    assert "| lost 2026-12-06 after 78 epochs | 49 | 82 % [73, 88] | 99 % [95, 100] |" in section, section
    # Once this attempt reaches the lost one's furthest snapshot, the opening table reads this attempt's.
    for label, run in rr.RUNS.items():
        run_dir(records / run / "extra", 0, {49: 90})
        for f in (records / run / "extra" / "snapshots").iterdir():
            f.rename(records / run / "snapshots" / f.name)
    last, of = rr.latest(rr.interim(records))
    assert last["epoch"] == 49 and of is None and last["Dense"]["test"]["successes"] == 90

with tempfile.TemporaryDirectory() as tmp:
    subprocess.run([sys.executable, str(REPO / "scripts/reproduction_report.py"), "--out", tmp], check=True,
                   stdout=subprocess.DEVNULL)
    out = Path(tmp)
    written = sorted(p.relative_to(out) for p in out.rglob("*") if p.is_file())
    for rel in written:
        committed = REPO / "docs" / rel
        assert committed.exists(), f"docs/{rel} is not committed: run scripts/reproduction_report.py"
        assert committed.read_bytes() == (out / rel).read_bytes(), \
            f"docs/{rel} differs from what the records give: run scripts/reproduction_report.py"
    stale = sorted(p.relative_to(REPO / "docs") for p in (REPO / "docs/report").glob("*")) 
    assert all(Path(rel) in written for rel in stale), f"docs/report/ holds files the report no longer writes: {stale}"
print(f"ok: docs/report.md and its {len(written) - 1} figure(s) are what the records give")
