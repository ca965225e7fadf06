#!/usr/bin/env python3
"""The committed reproduction report is what the committed records give:
scripts/reproduction_report.py run again into a scratch directory writes
docs/report.md and every figure it links byte for byte; and its verdicts
follow the rule it states (checked on made-up intervals)."""
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
