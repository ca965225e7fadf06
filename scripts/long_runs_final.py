#!/usr/bin/env python3
"""The end of the long runs (issue 37, item 4): the runs against the paper.

Used by `scripts/long_runs.sh finish` and by scripts/long_runs_record.py:

    long_runs_final.py best RECORDS/<run>
        prints the snapshot epoch best on the validation episodes (ties: the
        earlier), the one rule by which a snapshot is chosen
    long_runs_final.py readme RECORDS/<run> PRETRAINED/<run><suffix> --commit C [--heading H] [--results R]
        writes the README of the run's exported policies; H is the heading of
        the campaign's section (default HEADING), R the file it is in

and, imported by the record script, `section_lines`: the part of the
campaign's section that compares the ended runs with the paper's Tables I
and II, row by row, on each engine.

A campaign of the keeper is one pair of runs with its records, its policies in
pretrained/<run><suffix>/ and its section under its own heading. The first,
the paper's budget, is addressed with PAPER_BUDGET_HEADING and the suffix
`_paper` (its section is in docs/notebook/results.md); the defaults, HEADING and
SUFFIX, are the second's, the paper's stack at the paper's budget.

The paper's numbers (egg and block rows of Tables I and II) are written out
below as printed. Only the success rates and drop counts are on a common
scale with ours: the paper's contact counts and grasp measures come from its
own model and units (its egg totals 6595 contacts, ours about 400), so for
those it is the paper's ordering of two methods that is compared, not its
values. An ordering is supported when our 95 % interval of the difference
lies on the paper's side of zero, contradicted when it lies on the other
side, and otherwise cannot be told. Rates: Wilson intervals, and Newcombe's
hybrid score interval for a difference of two independent rates; means: the
normal interval of a difference of means with each mean's standard error
(std / sqrt(n), Welch).
"""

import argparse
import csv
import json
import math
import os
import statistics
import sys
import tomllib
from pathlib import Path

Z = 1.959963984540054

# Table I (100 trials): success %, then (mean, std) of total contact, Q_MSV,
# Q_VEW, Q'_MSV, Q'_VEW and Q_DCC in 1e-3 m.
MEASURES = ["contacts", "q_msv", "q_vew", "dq_msv", "dq_vew", "q_dcc"]
PAPER_TABLE1 = {
    "block": {
        "Dense+FMSR+IS": (86, (7614, 331), (919, 145), (2644, 223), (10, 60), (61, 173), (6.9, 2.4)),
        "Dense+FMSR": (67, (5787, 251), (667, 245), (1558, 247), (58, 122), (91, 171), (15.6, 3.6)),
        "Dense": (61, (5359, 263), (434, 85), (1276, 275), (36, 70), (128, 269), (17.6, 5.3)),
        "Sparse": (92, (5621, 451), (441, 178), (1685, 436), (48, 82), (86, 131), (19.3, 9.2)),
    },
    "egg": {
        "Dense+FMSR+IS": (91, (6595, 374), (1072, 173), (2175, 251), (55, 152), (125, 276), (3.8, 2.5)),
        "Dense+FMSR": (43, (5846, 269), (912, 151), (1714, 304), (38, 101), (129, 212), (6.5, 3.3)),
        "Dense": (35, (5624, 203), (707, 80), (1266, 341), (23, 68), (191, 245), (8.1, 1.9)),
        "Sparse": (94, (6019, 496), (764, 213), (1584, 396), (67, 94), (168, 218), (5.9, 4.1)),
    },
}
# Table II (500 trials): failures, incomplete, drops.
PAPER_TABLE2 = {
    "block": {"Dense+FMSR+IS": (61, 60, 1), "Sparse": (42, 26, 16)},
    "egg": {"Dense+FMSR+IS": (53, 53, 0), "Sparse": (37, 24, 13)},
}
PAPER_TRIALS = {"table1": 100, "table2": 500}
LABELS = {"dense_fmsr_is": "Dense+FMSR+IS", "dense_fmsr": "Dense+FMSR", "dense": "Dense", "sparse": "Sparse"}
NAMES = {
    "contacts": "Total contact",
    "q_msv": "Q_MSV",
    "q_vew": "Q_VEW",
    "dq_msv": "\\|Q'_MSV\\|",
    "dq_vew": "\\|Q'_VEW\\|",
    "q_dcc": "Q_DCC",
}
# Our evaluation's field for each measure, and the scale it is shown at.
FIELDS = {
    "contacts": ("total_contacts", 1.0, 0),
    "q_msv": ("q_msv", 1.0, 4),
    "q_vew": ("q_vew", 1.0, 5),
    "dq_msv": ("dq_msv", 1.0, 3),
    "dq_vew": ("dq_vew", 1.0, 4),
    "q_dcc": ("q_dcc", 1e3, 1),
}
# Each set on each engine, named by `fmsr eval --engine` (scripts/long_runs.sh
# carry_evaluations): the validation episodes on both, since a MuJoCo-trained
# run's snapshots are chosen on MuJoCo's.
FINALS = ["test-rapier", "validation-rapier", "test-mujoco", "validation-mujoco", "trials-rapier", "trials-mujoco"]
ENGINES = ("rapier", "mujoco")

# The campaigns (scripts/long_runs.sh): the section's heading and the suffix of
# the runs' directories in pretrained/. The defaults are the current campaign's.
PAPER_BUDGET_HEADING = "The paper's budget: the egg, Dense+FMSR+IS against Dense, 400 epochs"
HEADING = "The paper's stack at the paper's budget: the egg, Dense+FMSR+IS against Dense, 400 epochs"
SUFFIX = "_paper_stack"
RESULTS = "docs/results/paper_stack/README.md"


def short_name(heading):
    """The campaign's name in running text: its heading before the colon (`The paper's budget`)."""
    return heading.split(":", 1)[0]


def lower_first(text):
    return text[:1].lower() + text[1:]


def at(heading):
    """The campaign's name as a sentence's opening: `At the paper's budget`, `With the paper's stack at ...`."""
    name = lower_first(short_name(heading))
    return ("At " if name.startswith("the paper's budget") else "With ") + name


def wilson(k, n):
    """The 95 % Wilson interval (p, lo, hi) of k successes in n; None when n is 0."""
    if n == 0:
        return None
    p = k / n
    d = 1 + Z * Z / n
    c = (p + Z * Z / (2 * n)) / d
    h = Z / d * math.sqrt(p * (1 - p) / n + Z * Z / (4 * n * n))
    return p, max(0.0, c - h), min(1.0, c + h)


def training_threshold(config_path):
    """The training threshold (rad) of a run: `env.success_threshold` of its config.toml, rounded to 6 decimals (the
    binary writes the f32, 0.10000000149011612), the distance the precision tables count episodes within. None when
    the file or the key is missing or unreadable: those tables are then left out, never drawn at a guessed value."""
    try:
        return round(float(tomllib.loads(Path(config_path).read_text())["env"]["success_threshold"]), 6)
    except (OSError, KeyError, TypeError, ValueError, tomllib.TOMLDecodeError):
        return None


def final_angles(e, within):
    """How close the episodes of evaluation `e` ended to their goals, by the full angle between the quaternions:
    the median final angle, its parts' medians (the error about the vertical and the tilt from it, when recorded),
    and the Wilson interval of the episodes that ended within `within` rad of the goal (the run's training
    threshold, `training_threshold`) without a drop. All None for an evaluation whose records hold no full angle
    (before 2026-11-27); `precise` None also when `within` is None. Under gym's goal distance (`goal_distance =
    "gym"`, the paper's stack) an episode is within by gym's own distance, its `final_error`: one that ends at the
    goal's double cover (the object turned the short way) is a small angle from the goal but 2 pi from it by gym."""
    orient = [r.get("orientation", {}) for r in e.get("records", [])]
    angles = [o.get("full_angle") for o in orient]
    if not angles or any(a is None for a in angles):
        return {"median_angle": None, "median_yaw": None, "median_tilt": None, "precise": None, "within": within}
    part = lambda key: None if any(o.get(key) is None for o in orient) else statistics.median(o[key] for o in orient)
    distances = [r["final_error"] for r in e["records"]] if e.get("goal_distance") == "gym" else angles
    close = None if within is None else \
        sum(1 for a, r in zip(distances, e["records"]) if a < within and not r.get("dropped"))
    return {"median_angle": statistics.median(angles), "median_yaw": part("yaw_error"), "median_tilt": part("tilt"),
            "precise": None if close is None else wilson(close, len(angles)), "within": within}


def angle_cell(p):
    """A median final angle with its parts, as the tables write it: `0.115 (yaw 0.046, tilt 0.097)`."""
    parts = "" if p["median_yaw"] is None or p["median_tilt"] is None else \
        f" (yaw {p['median_yaw']:.3f}, tilt {p['median_tilt']:.3f})"
    return f"{p['median_angle']:.3f}{parts}"


def within_label(thresholds):
    """The column label of the precision tables for the runs' training thresholds: `within 0.1 rad` when they
    agree; one per run otherwise, when the shares measure different things and no difference is taken."""
    return f"{thresholds[0]:g} rad" if len(set(thresholds)) == 1 else \
        " and ".join(f"{t:g}" for t in thresholds) + " rad (each run's own; no difference taken)"


def precision_rows(ea, eb, labels, within):
    """How close the episodes of evaluations ea and eb ended to their goals (ours, not the paper's measure):
    a table of two rows and the difference, or nothing when either lacks the full angle or its threshold.
    `within`: the two runs' training thresholds; the difference only when they agree."""
    pa, pb = final_angles(ea, within[0]), final_angles(eb, within[1])
    if pa["precise"] is None or pb["precise"] is None:
        return []
    diff = pts(newcombe(pa["precise"], pb["precise"])) if within[0] == within[1] else "n/a (thresholds differ)"
    return [f"| Run | Median final angle (rad) | Within {within_label(list(within))}, not dropped ({ea['episodes']}) |",
            "|---|---|---|",
            f"| {labels[0]} | {angle_cell(pa)} | {pct(pa['precise'])} |",
            f"| {labels[1]} | {angle_cell(pb)} | {pct(pb['precise'])} |",
            f"| Difference | | {diff} |"]


def precision_blocks(a, b, engine, name):
    """The final section's tables of how close runs a and b (their `finals` and `within`) ended to their goals on
    `engine` (shown as `name`): the fixed test set, then Table II's trials (the first TRIALS test episodes, the test
    set among them: more episodes of the same draw) where both runs have them. Nothing for an evaluation without
    the full angle."""
    lines = []
    test = a["finals"].get(f"test-{engine}")
    for key in (f"test-{engine}", f"trials-{engine}"):
        ea, eb = a["finals"].get(key), b["finals"].get(key)
        rows = precision_rows(ea, eb, (a["label"], b["label"]), (a["within"], b["within"])) if ea and eb else []
        if not rows:
            continue
        if key.startswith("test-"):
            title = (f"**How close the test episodes ended to their goals, {name}** (ours, not the paper's measure: "
                     "the success rule at 0.4 rad cannot separate two runs near its ceiling):")
        else:
            among = f", the {test['episodes']} above among them" if test else ""
            title = (f"**The same over Table II's {ea['episodes']} trials, {name}** (the first {ea['episodes']} "
                     f"test episodes{among}: more episodes of the same draw, a narrower interval):")
        lines += [title, ""] + rows + [""]
    return lines


def newcombe(a, b):
    """Difference a - b of two Wilson intervals (p, lo, hi), Newcombe's hybrid score interval."""
    d = a[0] - b[0]
    return d, d - math.sqrt((a[0] - a[1]) ** 2 + (b[2] - b[0]) ** 2), d + math.sqrt((a[2] - a[0]) ** 2 + (b[0] - b[1]) ** 2)


def mean_difference(a, b):
    """Difference of two (mean, std, n) with its 95 % normal interval."""
    d = a[0] - b[0]
    h = Z * math.sqrt(a[1] ** 2 / a[2] + b[1] ** 2 / b[2])
    return d, d - h, d + h


def verdict(paper_sign, ours):
    """Whether our interval of a difference supports the paper's sign of it."""
    _, lo, hi = ours
    if paper_sign == 0:
        return "the paper shows no difference"
    if lo > 0 or hi < 0:
        return "**supports**" if (lo > 0) == (paper_sign > 0) else "**contradicts**"
    return "cannot tell"


def pct(i):
    return "n/a" if i is None else f"{100 * i[0]:.0f} % [{100 * i[1]:.0f}, {100 * i[2]:.0f}]"


def points(x):
    """A signed difference of rates in whole points, unless it rounds to zero without being zero: then
    with as many decimals as it takes (up to three) to show its sign, so that an interval's end that
    excludes zero never reads as zero."""
    v = 100 * x
    for decimals in range(4):
        s = f"{v:+.{decimals}f}"
        if v == 0 or s.strip("+-0.") != "":
            return s
    return s


def pts(i):
    return f"{points(i[0])} pts [{points(i[1])}, {points(i[2])}]"


def read_json(path):
    return json.loads(path.read_text()) if path.exists() else None


def success(e):
    return wilson(e["outcomes"]["successes"], e["outcomes"]["episodes"])


def drops(e):
    return wilson(e["outcomes"]["drop"], e["outcomes"]["episodes"])


def measure(e, key):
    field, scale, _ = FIELDS[key]
    s = (e.get("stability") or {}).get(field)
    return None if s is None else (s["mean"] * scale, s["std"] * scale, s["n"])


def best(run_records):
    """The snapshot epoch best on the validation episodes (ties: the earlier), or None."""
    scored = []
    for p in sorted((run_records / "snapshots").glob("epoch-*.validation.json")):
        scored.append((success(json.loads(p.read_text()))[0], -int(p.name.split(".")[0][6:])))
    return -max(scored)[1] if scored else None


def config_value(config, key, default=None):
    """A top-level string key of a run's config.toml text (before its first table), else `default`."""
    for line in config.splitlines():
        if line.lstrip().startswith("["):
            break
        k, eq, v = line.partition("=")
        if eq and k.strip() == key:
            return v.split("#", 1)[0].strip().strip('"')
    return default


def load_final(run_records):
    """A run's final evaluations, or None until `finish` wrote them all."""
    d = run_records / "final"
    finals = {k: read_json(d / f"{k}.json") for k in FINALS}
    if any(v is None for v in finals.values()):
        return None
    # The shipped file's own evaluations, at half precision (absent before it was shipped so).
    halves = {k: read_json(d / f"{k}-half.json") for k in FINALS if not k.startswith("trials")}
    config = (run_records / "config.toml").read_text()
    method = config_value(config, "method")
    k = best(run_records)
    snap = read_json(run_records / "snapshots" / f"epoch-{k:03d}.test.json") if k is not None else None
    val = read_json(run_records / "snapshots" / f"epoch-{k:03d}.validation.json") if k is not None else None
    # By the column's name: its place moved when metrics.csv gained columns
    # (2026-11-27), and the fifth column became train_success_rate.
    with open(run_records / "metrics.csv", newline="") as fh:
        metrics = list(csv.DictReader(fh))
    env_steps = int(metrics[-1]["env_steps"]) if metrics else 0
    return {"name": run_records.name, "label": LABELS[method], "task": finals["test-rapier"]["task"],
            "engine": engine_of(finals["test-rapier"], "trained_on"), "finals": finals, "halves": halves, "best": k, "best_test": snap, "best_validation_episodes": val["episodes"] if val else 0,
            "epochs": len(metrics), "env_steps": env_steps,
            "within": training_threshold(run_records / "config.toml")}


ORDERING_HEADER = ["| Measure | The paper: Dense+FMSR+IS | The paper: Dense | Ours: Dense+FMSR+IS | Ours: Dense | "
                   "Ours: difference (95 %) | The paper's ordering |", "|---|---|---|---|---|---|---|"]


def ordering_rows(ta, tb, task, labels):
    """Test success and Table I's measures of evaluation ta against tb, beside the paper's rows for `labels`."""
    pa, pb = PAPER_TABLE1[task][labels[0]], PAPER_TABLE1[task][labels[1]]
    rows = []
    sa, sb = success(ta), success(tb)
    rows.append(f"| Success (test, {ta['episodes']}) | {pa[0]} % | {pb[0]} % | {pct(sa)} | {pct(sb)} | "
                f"{pts(newcombe(sa, sb))} | {verdict(pa[0] - pb[0], newcombe(sa, sb))} |")
    for i, key in enumerate(MEASURES):
        ma, mb = measure(ta, key), measure(tb, key)
        (xa, sda), (xb, sdb) = pa[i + 1], pb[i + 1]
        if ma is None or mb is None:
            rows.append(f"| {NAMES[key]} | {xa}±{sda} | {xb}±{sdb} | n/a | n/a | n/a | not measured |")
            continue
        p = FIELDS[key][2]
        d = mean_difference(ma, mb)
        rows.append(f"| {NAMES[key]} | {xa}±{sda} | {xb}±{sdb} | {ma[0]:.{p}f}±{ma[1]:.{p}f} | {mb[0]:.{p}f}±{mb[1]:.{p}f} | "
                    f"{d[0]:+.{p}f} [{d[1]:+.{p}f}, {d[2]:+.{p}f}] | {verdict(xa - xb, d)} |")
    return rows


def table1_rows(a, b, engine):
    """Success and Table I's measures, a against b on one engine, beside the paper's; then the drops in the trials."""
    rows = ordering_rows(a["finals"][f"test-{engine}"], b["finals"][f"test-{engine}"], a["task"], (a["label"], b["label"]))
    trials = a["finals"][f"trials-{engine}"], b["finals"][f"trials-{engine}"]
    rows.append(drops_row(*trials, a["task"], (a["label"], b["label"]), f"{trials[0]['episodes']} trials"))
    return rows


def drops_row(ea, eb, task, labels, what):
    """The drops of evaluation ea against eb, beside the paper's Table II for labels[0] (it has no Dense row)."""
    da, db = drops(ea), drops(eb)
    paper_drops = PAPER_TABLE2[task].get(labels[0])
    return (f"| Drops ({what}; the paper's Table II has no Dense row) | "
            f"{f'{paper_drops[2]} of 500' if paper_drops else 'n/a'} | n/a | {pct(da)} | {pct(db)} | "
            f"{pts(newcombe(da, db))} | {verdict(-1, newcombe(da, db))} (the paper's conclusion: fewer drops) |")


def against_paper(d, fewer="below", more="above"):
    """Where our rate lies against the paper's, from the interval d of ours minus the paper's."""
    return "as the paper" if d[1] <= 0 <= d[2] else (f"{fewer} the paper" if d[2] < 0 else f"{more} the paper")


# How the results name the engine an evaluation's JSON gives (`engine`,
# `trained_on`).
ENGINE_NAMES = {"rapier": "rapier", "mujoco": "MuJoCo"}


def engine_of(e, key="engine"):
    """The engine an evaluation ran on (or, with key="trained_on", its policy
    trained on); rapier for evaluations written before the field existed."""
    return e.get(key, "rapier")


def shown(engine):
    """An engine's key (`rapier`, `mujoco`) as the results write it."""
    return ENGINE_NAMES.get(engine, engine)


def engine_name(e, key="engine"):
    """engine_of, as the results write it."""
    return shown(engine_of(e, key))


def trained_first(home):
    """Both engines, `home` (the one a run trained on) first: its rows lead."""
    return (home,) + tuple(e for e in ENGINES if e != home)


def read_restarts(path):
    """The restarts of a run from its rescue points (restarts.jsonl): one JSON object a line, none without the file."""
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def best_on(r, engine):
    """The best snapshot's test evaluation when it was on `engine`, else None.

    Snapshots are evaluated on the engine the run trains on (`fmsr eval` of a
    policy file), so a MuJoCo-trained run's best snapshot belongs in the
    MuJoCo rows, not the rapier ones."""
    e = r["best_test"]
    return e if e is not None and engine_of(e) == engine else None


def absolute_rows(runs, engine):
    """Success and drop rates against the paper's own values (on a common scale)."""
    rows = []
    for r in runs:
        paper = PAPER_TABLE1[r["task"]].get(r["label"])
        if paper is None:
            continue
        p = wilson(paper[0], PAPER_TRIALS["table1"])
        for what, e in (("after the last epoch", r["finals"][f"test-{engine}"]),
                        (f"snapshot best on validation (epoch {r['best']} from 0)", best_on(r, engine))):
            if e is None:
                continue
            s = success(e)
            d = newcombe(s, p)
            rows.append(f"| {r['label']} | success, {what} | {pct(p)} | {pct(s)} | "
                        f"{pts(d)} | {against_paper(d)} |")
        t2 = PAPER_TABLE2[r["task"]].get(r["label"])
        if t2:
            p = wilson(t2[2], PAPER_TRIALS["table2"])
            e = r["finals"][f"trials-{engine}"]
            s = drops(e)
            d = newcombe(s, p)
            rows.append(f"| {r['label']} | drops after the last epoch ({e['episodes']} trials) | {pct(p)} | {pct(s)} | {pts(d)} | "
                        f"{against_paper(d, 'fewer than', 'more than')} |")
    return rows


def table2_rows(runs, engine):
    rows = []
    for r in runs:
        e = r["finals"][f"trials-{engine}"]
        f = e["failures"]
        share = "n/a" if not f["failures"] else f"{100 * f['drop'] / f['failures']:.1f} %"
        rows.append(f"| {r['label']} (ours, {shown(engine)}) | {e['episodes']} | {f['failures']} | {f['incomplete']} | {f['drop']} | {share} |")
    for label, (fail, inc, drop) in PAPER_TABLE2[runs[0]["task"]].items():
        rows.append(f"| {label} (the paper) | 500 | {fail} | {inc} | {drop} | {100 * drop / fail:.1f} % |")
    return rows


def trained_on(finals):
    """The engines the runs trained on, as the results write them."""
    return " and ".join(sorted({shown(f["engine"]) for f in finals}))


def section_lines(finals, records_rel, pretrained_rel):
    """The comparison with the paper of the runs' final evaluations (`load_final`), for the section of docs/notebook/results.md."""
    by_label = {f["label"]: f for f in finals}
    lines = ["", "### At the end: against the paper (issue 37, item 4)", "",
             "Written by `scripts/long_runs.sh finish`: the policy after the last epoch of each run (no selection), "
             f"evaluated on the fixed test set ({finals[0]['finals']['test-rapier']['episodes']} episodes), on the validation episodes and on the first "
             f"{finals[0]['finals']['trials-rapier']['episodes']} test episodes (the paper's Table II), on rapier "
             f"and on MuJoCo (trained on {trained_on(finals)}); evaluations in [`{records_rel}/<run>/final/`]({records_rel}/), "
             f"`fmsr report` over both in [`{records_rel}/report/summary.md`]({records_rel}/report/summary.md), "
             f"the policies in [`{pretrained_rel}/`]({pretrained_rel}/).", ""]
    for engine in trained_first(finals[0]["engine"]):
        name = shown(engine)
        lines += [f"**Against the paper's own values, {name}** (success and drops only: the other measures are on "
                  "the paper's scale, not ours):", "",
                  "| Run | What | The paper | Ours | Ours minus the paper | |", "|---|---|---|---|---|---|"]
        lines += absolute_rows(finals, engine)
        lines.append("")
        a, b = by_label.get("Dense+FMSR+IS"), by_label.get("Dense")
        if a and b:
            lines += [f"**The paper's orderings, Dense+FMSR+IS against Dense, {name}** (the paper's Table I: 100 trials; "
                      "our values mean ± std over the episodes):", ""] + ORDERING_HEADER
            lines += table1_rows(a, b, engine)
            lines.append("")
            lines += precision_blocks(a, b, engine, name)
        lines += [f"**Failure types (Table II), {name}:**", "",
                  "| Policy | Trials | Failures | Incomplete | Drops | Drops of the failures |", "|---|---|---|---|---|---|"]
        lines += table2_rows(finals, engine)
        lines.append("")
    for f in finals:
        k = f["best"]
        t = f["best_test"]
        lines.append(f"- {f['label']}: the snapshot best on validation ({f['best_validation_episodes']} episodes) is epoch {k}"
                     + (f", test success on {engine_name(t)} {pct(success(t))}" if t else "") + ".")
    return lines


def summary_bullet(finals, anchor, heading=HEADING):
    """The summary's line on the long runs once `finish` ran: the final policies' test success and drops."""
    cells = []
    # On the engine each run trained on (the pair's: MuJoCo, the paper's engine).
    test = lambda f: f["finals"][f"test-{f['engine']}"]
    for f in finals:
        t, n = test(f), f["finals"][f"trials-{f['engine']}"]
        cells.append(f"{f['label']} {pct(success(t))} ({n['outcomes']['drop']} drops in {n['episodes']} trials)")
    text = (f"- **{at(heading)} ({finals[0]['epochs']} epochs), egg, seed 0, ended:** the policies after "
            f"the last epoch reach, on the fixed test set on {trained_on(finals)} (the engine they trained on), "
            + " against ".join(cells))
    if len(finals) == 2:
        text += f"; difference {pts(newcombe(success(test(finals[0])), success(test(finals[1]))))}"
    paper = "; ".join(f"{f['label']} {PAPER_TABLE1[f['task']][f['label']][0]} %" for f in finals if f["label"] in PAPER_TABLE1[f["task"]])
    return f"{text}. The paper: {paper}. Row by row against the paper: [{lower_first(short_name(heading))}](#{anchor}).\n"


def pretrained_index(finals, suffix=SUFFIX, heading=HEADING):
    """The lines of pretrained/README.md on the long runs' policies (in pretrained/<run><suffix>/)."""
    lines = [f"{at(heading)} (issues 37 and 53, `scripts/long_runs.sh finish`; egg, seed 0, the paper's config), "
             "the policies after the last epoch, no selection; test and validation on the engine each trained on, "
             "then the test set on the other:", "",
             "| Policy | Configuration | Epochs | Trained on | Test success (100) | Validation | Test success, other engine (100) | "
             "Drops in the Table II trials | Best snapshot on validation: test success |", "|---|---|---|---|---|---|---|---|---|"]
    for f in finals:
        fin = f["finals"]
        home, other = trained_first(f["engine"])
        n = fin[f"trials-{home}"]
        best_cell = f"epoch {f['best']}: {pct(success(f['best_test']))}" if f["best_test"] else "n/a"
        lines.append(f"| [`{f['name']}{suffix}`]({f['name']}{suffix}/README.md) | {f['label']}, 6 agents | {f['epochs']} | "
                     f"{shown(home)} | **{pct(success(fin[f'test-{home}']))}** | {pct(success(fin[f'validation-{home}']))} | "
                     f"{shown(other)}: {pct(success(fin[f'test-{other}']))} | {n['outcomes']['drop']} of {n['episodes']} | {best_cell} |")
    return "\n".join(lines) + "\n"


def readme(run_records, out, commit, heading=HEADING, results=RESULTS):
    """Writes out/README.md, the README of a run's final policies; `results`: the file that holds the section
    headed `heading`, as a path from the repository's root."""
    f = load_final(run_records)
    if f is None:
        sys.exit(f"{run_records}: the final evaluations are not all there (run `scripts/long_runs.sh finish`)")
    env = dict(line.split("=", 1) for line in (run_records / "keeper.env").read_text().splitlines() if "=" in line)
    fin = f["finals"]
    home = f["engine"]
    rows = []
    for engine in trained_first(home):
        mark = " (trained on)" if engine == home else ""
        for kind, what in (("test", "fixed test set"), ("validation", "validation episodes"),
                           ("trials", "first test episodes (Table II)")):
            e = fin[f"{kind}-{engine}"]
            o = e["outcomes"]
            h = f["halves"].get(f"{kind}-{engine}")
            shipped = "" if h is None else pct(success(h))
            rows.append(f"| {what}, {shown(engine)}{mark} | {e['episodes']} | **{pct(success(e))}** | {o['incomplete']} | "
                        f"{o['drop']} | {shipped} |")
    best_line = (f"The snapshot best on the validation episodes is the final policy itself."
                 if f["best"] == int(env["EPOCHS"]) - 1 else
                 f"`best_on_validation.fmsr` is the snapshot after epoch {f['best']} (counted from 0), the best of the "
                 f"snapshots on {f['best_validation_episodes']} validation episodes on {shown(home)}: test success "
                 f"{pct(success(f['best_test']))}. It was chosen on "
                 "validation episodes, not on the test set, as the paper logs its best policy.")
    setup = "scripts/setup_mujoco.sh   # libmujoco, once\n" if home == "mujoco" else ""
    features = " --features mujoco" if home == "mujoco" else ""
    restarts = read_restarts(run_records / "restarts.jsonl")
    restart_line = ("" if not restarts else
                    " Restarted from its rescue point at epoch" + ("s " if len(restarts) > 1 else " ")
                    + ", ".join(str(r.get("restart", {}).get("epoch", "?")) for r in restarts)
                    + f" (the home was lost; replay refilled, `{results}` says what each lost).")
    # The binary the run ended with: its own commit's, or a restore's build (BIN_NOTE says which).
    note = env.get("BIN_NOTE", "").strip().strip('"')
    exporter = (f"the binary the run ended with (`{Path(env['BIN']).name}`" + (f": {note})" if note else ")")
                if env.get("BIN") else "the run's own binary")
    shipped_line = ("It is shipped at half precision (`fmsr export --precision half`, the actors as f16: about "
                    "half the bytes), carrying its own evaluations, played again at that precision (`fmsr eval ... "
                    "--record`; the table's last column, which `fmsr eval` repeats; `final/*-half.log` in the records "
                    "says how many episodes end otherwise)."
                    if any(v is not None for v in f["halves"].values()) else
                    "Its evaluations are written into the file (`fmsr eval ... --record`).")
    text = f"""# Egg, six agents, {f['label']}: {lower_first(short_name(heading))}

The long run of issues 37 and 53 (`scripts/long_runs.sh`): `{env.get('CONFIG', '?')}`, seed 0, trained on {shown(home)}, the paper's config
with one stepping thread and one learner thread, {f['epochs']} epochs ({f['env_steps']} env steps with the epochs'
evaluation episodes), started
{env.get('STARTED', '?')} with the release binary of commit `{env.get('COMMIT', '?')[:10]}`, on the project's
development VM (2 cores, no GPU), one core per run.{restart_line} Learning curve and snapshots: `{results}`,
section "{short_name(heading)}".

`policy.fmsr` is the policy after the last epoch (no selection), exported by {exporter} and
evaluated with the build of `{commit}` (`--features mujoco`). {shipped_line} {best_line}

```sh
{setup}cargo run --release{features} -- eval pretrained/{out.name}      # repeats the shipped file's test evaluation below on {shown(home)}
cargo run --release{features} -- render pretrained/{out.name}    # test episode 0 as a GIF, into render/ here
```

Success is turned and held (within {fin[f'test-{home}']['threshold']} rad at the last step, never dropped), with its 95 % Wilson interval:

| Episodes | Count | Success | Incomplete | Drops | Success, the file shipped (f16) |
|---|---|---|---|---|---|
""" + "\n".join(rows) + "\n"
    (out / "README.md").write_text(text)
    print(f"wrote {out / 'README.md'}")


def main():
    ap = argparse.ArgumentParser()
    sub = ap.add_subparsers(dest="cmd", required=True)
    b = sub.add_parser("best")
    b.add_argument("run_records", type=Path)
    r = sub.add_parser("readme")
    r.add_argument("run_records", type=Path)
    r.add_argument("out", type=Path)
    r.add_argument("--commit", required=True)
    r.add_argument("--heading", default=HEADING, help="the heading of the campaign's section")
    r.add_argument("--results", type=Path, default=None,
                   help="the file that holds the section (default: the repository's " + RESULTS + ")")
    a = ap.parse_args()
    if a.cmd == "best":
        k = best(a.run_records)
        if k is None:
            sys.exit(f"{a.run_records}: no snapshot evaluated on the validation episodes")
        print(k)
    else:
        root = Path(__file__).resolve().parent.parent
        results = RESULTS if a.results is None else os.path.relpath(a.results.resolve(), root)
        readme(a.run_records, a.out, a.commit, a.heading, results)


if __name__ == "__main__":
    main()
