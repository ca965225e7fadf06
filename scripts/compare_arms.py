#!/usr/bin/env python3
"""The arms of a lite experiment side by side, over their seeds (issue 52's
E2/E3/E5, issue 53's item 3): a markdown table of test success (the run's
own engine), drops, validation success and the test set on the other engine,
per run and pooled over an arm's seeds, and each arm's pooled difference
from the first arm.

    scripts/compare_arms.py "Dense+FMSR+IS=RUN_S0,RUN_S1" "Dense=RUN_S0,RUN_S1"

RUN is a run directory (or a copy of its records, as `docs/results/e2/<run>/`)
holding `eval.json` (the fixed test set on the run's engine),
`eval-validation.json` and `eval-<other engine>.json`, as
`scripts/lite_arm.sh` writes them.

Rates carry their 95 % Wilson interval; differences Newcombe's hybrid score
interval (`fmsr-core/src/interval.rs`, the same formulas). Pooling an arm's
seeds counts their episodes together (two seeds: 200 test episodes, the same
100 played by each seed's policy): the interval then holds the episodes'
chance, not the spread between seeds, so the per-seed rows are printed above
the pooled one and should be read with it.
"""

import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from long_runs_final import newcombe, wilson  # noqa: E402


def load(path):
    """An evaluation file, or None when the run has none."""
    return json.loads(path.read_text()) if path.exists() else None


def counts(e):
    """(successes, episodes, drops) of an evaluation, or None."""
    if e is None:
        return None
    o = e["outcomes"]
    return o["successes"], o["episodes"], o["drop"]


def rate(c):
    """`k/n = p % [lo, hi]` of counts, or a dash."""
    if c is None:
        return "—"
    p, lo, hi = wilson(c[0], c[1])
    return f"{100 * p:.0f} % [{100 * lo:.0f}, {100 * hi:.0f}] ({c[0]}/{c[1]})"


def pts(d):
    """A difference of rates in points with its interval."""
    return f"{100 * d[0]:+.0f} pts [{100 * d[1]:+.0f}, {100 * d[2]:+.0f}]"


def add(a, b):
    """Counts of two evaluations together (None where either is missing)."""
    if a is None or b is None:
        return None
    return tuple(x + y for x, y in zip(a, b))


def run_row(d):
    """One run's counts: test (own engine), validation, the other engine's test; and their names."""
    test = load(d / "eval.json")
    if test is None:
        sys.exit(f"{d}: no eval.json (the fixed test set on the run's engine)")
    engine = test["engine"]
    other = "rapier" if engine == "mujoco" else "mujoco"
    return {
        "engine": engine,
        "other": other,
        "distance": test.get("goal_distance", "yaw"),
        "still": test["still"]["successes"] if test.get("still") else None,
        "test": counts(test),
        "validation": counts(load(d / "eval-validation.json")),
        "cross": counts(load(d / f"eval-{other}.json")),
    }


def main(argv):
    if len(argv) < 1 or any("=" not in a for a in argv):
        sys.exit(__doc__)
    arms = []
    for a in argv:
        name, runs = a.split("=", 1)
        rows = [(Path(r), run_row(Path(r))) for r in runs.split(",") if r]
        if not rows:
            sys.exit(f"arm {name}: no runs")
        arms.append((name, rows))
    first = arms[0][1][0][1]
    for _, rows in arms:
        for d, r in rows:
            if (r["engine"], r["distance"]) != (first["engine"], first["distance"]):
                sys.exit(f"{d}: {r['engine']}, {r['distance']}; the first run: {first['engine']}, {first['distance']}")
    engine, other = first["engine"], first["other"]
    print(
        f"| Arm | Run | Test success, {engine} | Drops | Validation success, {engine} | Drops | "
        f"Test success, {other} | Drops |"
    )
    print("|---|---|---|---|---|---|---|---|")
    pooled = []
    for name, rows in arms:
        total = {"test": (0, 0, 0), "validation": (0, 0, 0), "cross": (0, 0, 0)}
        for d, r in rows:
            cells = [rate(r[k]) + f" | {r[k][2]}" if r[k] else "— | —" for k in ("test", "validation", "cross")]
            print(f"| {name} | `{d.name}` | " + " | ".join(cells) + " |")
            total = {k: add(total[k], r[k]) for k in total}
        if len(rows) > 1:
            cells = [rate(total[k]) + f" | {total[k][2]}" if total[k] else "— | —" for k in ("test", "validation", "cross")]
            print(f"| **{name}, {len(rows)} seeds pooled** | | " + " | ".join(cells) + " |")
        pooled.append((name, total))
    print()
    base_name, base = pooled[0]
    for name, total in pooled[1:]:
        parts = []
        for k, label in (("test", f"test, {engine}"), ("validation", f"validation, {engine}"), ("cross", f"test, {other}")):
            if total[k] and base[k]:
                a, b = wilson(*base[k][:2]), wilson(*total[k][:2])
                parts.append(f"{label} {pts(newcombe(a, b))}")
        print(f"- {base_name} minus {name}: " + "; ".join(parts))


if __name__ == "__main__":
    main(sys.argv[1:])
