#!/usr/bin/env python3
"""The arms of a lite experiment side by side, over their seeds (issue 52's
E2/E3/E5, issue 53's item 3): a markdown table of test success (the run's
own engine), drops, validation success and the test set on the other engine,
per run and pooled over an arm's seeds, and each arm's pooled difference
from the first arm; then where the test episodes ended (the median final
full angle with its parts about the vertical and the tilt from it, the
share that ended within the run's training threshold without a drop, the
mean total contact), per run and pooled, and the first arm's difference in
that share; last, the learning curves: each epoch's evaluation at the
training threshold (`metrics.csv`'s `success_rate`, `trainer.eval_episodes`
deterministic episodes an epoch) over every epoch and over the last ten,
and the first epoch at 50 % or more, per run and pooled, with the first
arm's difference over the last ten epochs.

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

import csv
import json
import sys
import tomllib
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from long_runs_final import angle_cell, final_angles, newcombe, pts, training_threshold, wilson  # noqa: E402


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
        # The test episodes' records (final angles, contacts) and the training threshold they are counted within.
        "records": test.get("records", []),
        "within": training_threshold(d / "config.toml"),
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
    print()
    ended_table(arms, engine)
    print()
    curve_table(arms)


def ended(records, within, distance):
    """Where episodes `records` ended: `final_angles`' medians and interval, the count within the threshold
    without a drop (`close`, None without a threshold or full angles; by gym's distance where `distance` is
    "gym", as `final_angles` counts), and the mean total contact (None unless every record has one)."""
    p = final_angles({"records": records, "goal_distance": distance}, within)
    p["episodes"] = len(records)
    p["close"] = None if p["precise"] is None else round(p["precise"][0] * len(records))
    contacts = [r["total_contacts"] for r in records if r.get("total_contacts") is not None]
    p["contact"] = sum(contacts) / len(contacts) if contacts and len(contacts) == len(records) else None
    return p


def ended_cells(p):
    """The cells of one row of `ended_table`."""
    angle = "—" if p["median_angle"] is None else angle_cell(p)
    if p["precise"] is None:
        close = "—"
    else:
        rate, lo, hi = p["precise"]
        close = f"{100 * rate:.0f} % [{100 * lo:.0f}, {100 * hi:.0f}] ({p['close']}/{p['episodes']})"
    contact = "—" if p["contact"] is None else f"{p['contact']:.0f}"
    return f"{angle} | {close} | {contact}"


def ended_table(arms, engine):
    """Where each run's and each arm's (seeds pooled) test episodes ended, and the first arm's difference in the
    share within the training threshold. The runs must share that threshold, else the shares are left out."""
    thresholds = {r["within"] for _, rows in arms for _, r in rows}
    distance = arms[0][1][0][1]["distance"]
    within = thresholds.pop() if len(thresholds) == 1 else None
    label = f"within {within:g} rad" if within is not None else "within the training threshold (the runs' differ)"
    if distance == "gym":
        label += " by gym's distance"
    print(f"Where the test episodes ended ({engine}; the median final angle over every episode, with the medians "
          f"of its parts; {label} and not dropped; the mean total contact of an episode):")
    print()
    print(f"| Arm | Run | Median final angle (rad) | {label[0].upper() + label[1:]}, not dropped | Total contact |")
    print("|---|---|---|---|---|")
    pooled = []
    for name, rows in arms:
        for d, r in rows:
            print(f"| {name} | `{d.name}` | {ended_cells(ended(r['records'], within, distance))} |")
        records = [e for _, r in rows for e in r["records"]]
        if len(rows) > 1:
            print(f"| **{name}, {len(rows)} seeds pooled** | | {ended_cells(ended(records, within, distance))} |")
        pooled.append((name, ended(records, within, distance)))
    base_name, base = pooled[0]
    lines = [f"- {base_name} minus {name}: {label} {pts(newcombe(base['precise'], p['precise']))}"
             for name, p in pooled[1:] if base["precise"] and p["precise"]]
    if lines:
        print()
        print("\n".join(lines))


LAST = 10


def curve(d):
    """A run's per-epoch evaluations at its training threshold: (successes per epoch, episodes an epoch), the
    successes rounded from `metrics.csv`'s rates; None without `metrics.csv` or `trainer.eval_episodes`."""
    try:
        n = int(tomllib.loads((d / "config.toml").read_text())["trainer"]["eval_episodes"])
        with open(d / "metrics.csv", newline="") as f:
            rows = list(csv.DictReader(f))
    except (OSError, KeyError, TypeError, ValueError, tomllib.TOMLDecodeError):
        return None
    if not rows or [int(r["epoch"]) for r in rows] != list(range(len(rows))):
        sys.exit(f"{d}/metrics.csv: the epochs are not 0, 1, 2, ... once each")
    return [round(float(r["success_rate"]) * n) for r in rows], n


def curve_cells(curves):
    """Mean over every epoch and over the last ten (pooled over `curves`' runs, Wilson intervals on the episodes),
    the first epoch at 50 % or more of each run, and the last ten's counts."""
    every = (sum(sum(k) for k, _ in curves), sum(len(k) * n for k, n in curves))
    last = (sum(sum(k[-LAST:]) for k, _ in curves), sum(len(k[-LAST:]) * n for k, n in curves))
    first = ", ".join(next((str(e) for e, x in enumerate(k) if x >= n / 2), "never") for k, n in curves)
    epochs = "/".join(sorted({str(len(k)) for k, _ in curves}))
    return f"{epochs} | {rate(every)} | {rate(last)} | {first}", last


def curve_table(arms):
    """The learning curves of each run and each arm (seeds pooled), and the first arm's difference over the last
    ten epochs (the pooled interval counts episodes, not seeds)."""
    print("Learning curves (each epoch's evaluation at the training threshold, deterministic episodes; the mean "
          f"over every epoch and over the last {LAST}; the first epoch at 50 % or more):")
    print()
    print(f"| Arm | Run | Epochs | Every epoch | Last {LAST} epochs | First epoch at 50 % |")
    print("|---|---|---|---|---|---|")
    pooled = []
    for name, rows in arms:
        curves = []
        for d, _ in rows:
            c = curve(d)
            print(f"| {name} | `{d.name}` | " + (curve_cells([c])[0] if c else "— | — | — | —") + " |")
            curves += [c] if c else []
        if len(curves) > 1:
            print(f"| **{name}, {len(curves)} seeds pooled** | | {curve_cells(curves)[0]} |")
        pooled.append((name, curve_cells(curves)[1] if curves else None))
    base_name, base = pooled[0]
    lines = [f"- {base_name} minus {name}: last {LAST} epochs {pts(newcombe(wilson(*base), wilson(*p)))}"
             for name, p in pooled[1:] if base and p]
    if lines:
        print()
        print("\n".join(lines))


if __name__ == "__main__":
    main(sys.argv[1:])
