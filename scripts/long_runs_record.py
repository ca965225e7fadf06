#!/usr/bin/env python3
"""Writes the section of a campaign of the long runs from its records.

Called by `scripts/long_runs.sh record` after it has copied each run's small
files into the campaign's records (RECORDS/<run>/, by default
docs/results/paper_stack/<run>/) and evaluated its new snapshots. It reads
only those copies and the keeper's home (for whether a driver is alive; a run
marked lost by `scripts/long_runs.sh lost` has a lost.env beside its copies,
and no home), and replaces what lies between the section's two markers in the
results file (`--results`, by default RECORDS/README.md, created when missing;
the section is appended when the file has no markers). It also draws the
learning curves side by side as an SVG, RECORDS/curves.svg.

The campaign is named by `--heading` (the section's heading; default the
paper's stack at the paper's budget), `--suffix` (its runs' directories in
pretrained/, <run><suffix>; default `_paper_stack`) and its markers, by default
the records directory's name with `-` for `_` (`paper-stack`, and for the
first campaign, docs/results/paper_budget, `paper-budget`): the section's
`<!-- M:begin ... -->`, the summary's `M-summary` and pretrained/README.md's
`M-policies`, each written only where its markers are. The first campaign,
as it was written:

    long_runs_record.py --records docs/results/paper_budget --results docs/notebook/results.md --suffix _paper \
        --heading "The paper's budget: the egg, Dense+FMSR+IS against Dense, 400 epochs" ...

Success intervals are 95 % Wilson intervals, and differences Newcombe's hybrid
score intervals (long_runs_final.py's, the formulas of fmsr_core::interval).
"""

import argparse
import csv
import json
import math
import os
import platform
import subprocess
import tempfile
import tomllib
from pathlib import Path

import long_runs_final
import long_runs_restarts
from long_runs_final import (angle_cell, final_angles, newcombe as difference, pct, pts, training_threshold, wilson,
                              within_label)

# The markers of a campaign's parts, from its markers' name (`paper-budget`, `paper-stack`).
BEGIN = "<!-- {}:begin (written by scripts/long_runs.sh record) -->"
END = "<!-- {}:end -->"
LABELS = {"egg_dense_fmsr_is": "Dense+FMSR+IS", "egg_dense": "Dense"}


def read_metrics(path):
    if not path.exists():
        return []
    with path.open() as f:
        return list(csv.DictReader(f))


def read_eval(path, within):
    if not path.exists():
        return None
    e = json.loads(path.read_text())
    k = round(e["success_rate"] * e["episodes"])
    drops = sum(1 for r in e.get("records", []) if r.get("dropped"))
    return {"interval": wilson(k, e["episodes"]), "episodes": e["episodes"], "drops": drops,
            "rule": e["success_rule"], **final_angles(e, within)}


def trim(path):
    """Keeps a snapshot's evaluation small in the tree: every field but the
    per-episode grasp summaries and the first episode's per-step trace (the
    .log beside it has Table I's row), as compact JSON. ~110 KB to ~15 KB."""
    e = json.loads(path.read_text())
    if "episode_summaries" not in e and "trace" not in e:
        return
    e.pop("episode_summaries", None)
    e.pop("trace", None)
    write_atomic(path, json.dumps(e, separators=(",", ":")) + "\n")


def keeper_env(path):
    env = {}
    if path.exists():
        for line in path.read_text().splitlines():
            if "=" in line:
                k, v = line.split("=", 1)
                # A value the shell sources quoted (BIN_NOTE="...") is read without its quotes.
                env[k] = v[1:-1] if len(v) >= 2 and v[0] == v[-1] == '"' else v
    return env


def alive(home, run):
    lock = home / run / "keeper.lock"
    if not lock.exists():
        return False
    return subprocess.run(["flock", "-n", str(lock), "true"], capture_output=True).returncode != 0


def median(xs):
    xs = sorted(xs)
    if not xs:
        return None
    m = len(xs) // 2
    return xs[m] if len(xs) % 2 else (xs[m - 1] + xs[m]) / 2


def machine():
    cpu = "unknown CPU"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    mem = ""
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemTotal:"):
                mem = f", {int(line.split()[1]) / 1024 / 1024:.0f} GiB"
    except OSError:
        pass
    return f"{os.cpu_count()} cores ({cpu}){mem}, {platform.system()}"


def svg_axes(total, left=50, bottom=40, label_y=6, w=760, h=360, top=20, right=170):
    """An SVG chart of success (0 to 1) over `total` epochs: its opening lines
    (grid, ticks, the epoch axis's label) and its x and y maps."""
    x = lambda e: left + (w - left - right) * e / max(total, 1)
    y = lambda v: top + (h - top - bottom) * (1 - v)
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="12">',
           f'<rect width="{w}" height="{h}" fill="white"/>']
    for v in (0, 0.25, 0.5, 0.75, 1.0):
        out.append(f'<line x1="{left}" x2="{w - right}" y1="{y(v):.1f}" y2="{y(v):.1f}" stroke="#ddd"/>')
        out.append(f'<text x="{left - 6}" y="{y(v) + 4:.1f}" text-anchor="end">{v:.2f}</text>')
    for e in range(0, total + 1, 50):
        out.append(f'<text x="{x(e):.1f}" y="{h - bottom + 16}" text-anchor="middle">{e}</text>')
    out.append(f'<text x="{(w - right + left) / 2}" y="{h - label_y}" text-anchor="middle">epoch (20k env steps each)</text>')
    return out, x, y


def svg_curves(runs, path):
    """Eval success per epoch (thin) and test success at the snapshots (dots)."""
    w, h, left, bottom, top, right = 760, 360, 50, 40, 20, 170
    total = max([r["planned"] for r in runs] + [1])
    out, x, y = svg_axes(total)
    colors = {"Dense+FMSR+IS": "#1f77b4", "Dense": "#e6ab02"}
    for i, r in enumerate(runs):
        c = colors.get(r["label"], "#555")
        for key, dash in (("train_success_rate", "4 3"), ("success_rate", "")):
            pts_ = " ".join(f"{x(int(m['epoch']) + 1):.1f},{y(float(m[key])):.1f}" for m in r["metrics"])
            if pts_:
                out.append(f'<polyline fill="none" stroke="{c}" stroke-width="1.2" stroke-dasharray="{dash}" points="{pts_}"/>')
        for restart in r.get("restarts", []):
            e = restart.get("restart", {}).get("epoch")
            if e is not None:
                out.append(f'<line x1="{x(e):.1f}" x2="{x(e):.1f}" y1="{y(0):.1f}" y2="{y(1):.1f}" stroke="{c}" '
                           'stroke-dasharray="2 4"/>')
                out.append(f'<text x="{x(e) + 3:.1f}" y="{y(1) + 12 + 12 * i:.1f}" fill="{c}" font-size="10">restart</text>')
        for epoch, ev in r["snapshots"]:
            if ev["test"]:
                p, lo, hi = ev["test"]["interval"]
                out.append(f'<line x1="{x(epoch + 1):.1f}" x2="{x(epoch + 1):.1f}" y1="{y(lo):.1f}" y2="{y(hi):.1f}" stroke="{c}"/>')
                out.append(f'<circle cx="{x(epoch + 1):.1f}" cy="{y(p):.1f}" r="3.5" fill="{c}"/>')
        ly = top + 14 + 48 * i
        out.append(f'<text x="{w - right + 10}" y="{ly}" fill="{c}">{r["label"]}</text>')
        out.append(f'<text x="{w - right + 10}" y="{ly + 14}" fill="{c}" font-size="10">solid: eval, dashed: train</text>')
        out.append(f'<text x="{w - right + 10}" y="{ly + 28}" fill="{c}" font-size="10">dots: test, 95 % interval</text>')
    out.append("</svg>")
    write_atomic(path, "\n".join(out) + "\n")


def write_atomic(path, text):
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-")
    with os.fdopen(fd, "w") as f:
        f.write(text)
    os.chmod(tmp, 0o644)
    os.replace(tmp, path)


def load_run(records, home, name):
    d = records / name
    env = keeper_env(d / "keeper.env")
    metrics = read_metrics(d / "metrics.csv")
    snaps = []
    within = training_threshold(d / "config.toml")
    for p in sorted((d / "snapshots").glob("epoch-*.json")) + sorted((d / "final").glob("*.json")):
        trim(p)
    for p in sorted((d / "snapshots").glob("epoch-*.test.json")):
        k = int(p.name.split(".")[0].split("-")[1])
        snaps.append((k, {"test": read_eval(p, within),
                          "validation": read_eval(d / "snapshots" / f"epoch-{k:03d}.validation.json", within)}))
    return {
        "name": name,
        "dir": d,
        "label": LABELS.get(name, name),
        "env": env,
        "planned": int(env.get("EPOCHS", "400")),
        "metrics": metrics,
        "snapshots": snaps,
        # The training threshold (rad) the precision table counts episodes within, from config.toml.
        "within": within,
        "alive": alive(home, name),
        # Restarts from the run's rescue point (`fmsr train --rescue`), as restarts.jsonl records them.
        "restarts": long_runs_final.read_restarts(d / "restarts.jsonl"),
        # (eval, training) episodes an epoch, for what a restart cost (long_runs_restarts).
        "per_epoch": long_runs_restarts.episodes_per_epoch(d / "config.toml"),
        # When the keeper found the home gone (`long_runs.sh lost`), else None.
        "lost": keeper_env(d / "lost.env").get("FOUND") if (d / "lost.env").exists() else None,
    }


def buffer_capacity(config_path):
    """The replay buffer's capacity in episodes (`replay.buffer_size` // `env.episode_len`) of a run's config.toml, else None."""
    try:
        config = tomllib.loads(config_path.read_text())
        return int(config["replay"]["buffer_size"]) // int(config["env"]["episode_len"])
    except (OSError, KeyError, TypeError, ValueError, ZeroDivisionError, tomllib.TOMLDecodeError):
        return None


def buffer_lost(restarts, capacity):
    """The episodes the replay buffer held at each restart, all lost: `buffer_episodes` where the binary
    counted it (since 2026-11-29), else those stored since the previous restart (its `lost_episodes`, the
    replay floor) at most the buffer's `capacity`; None where neither says."""
    out, floor = [], 0
    for x in restarts:
        re_ = x.get("restart", {})
        held, lost = re_.get("buffer_episodes"), re_.get("lost_episodes")
        if held is None and isinstance(lost, int) and capacity is not None:
            held = min(lost - floor, capacity)
        out.append(held)
        floor = lost if isinstance(lost, int) else floor
    return out


def restarts_note(r):
    """A sentence per restart of run `r` from its rescue point: when, what it kept and lost, which binary."""
    out = []
    restarts = r.get("restarts", [])
    held = buffer_lost(restarts, buffer_capacity(r["dir"] / "config.toml"))
    for x, h in zip(restarts, held):
        re_, binary = x.get("restart", {}), x.get("binary", {})
        lost = "the replay buffer" + (
            "" if h is None else f" ({h} episodes of the {re_.get('lost_episodes', '?')} stored over the run)")
        out.append(
            f" Restarted at epoch {re_.get('epoch', '?')} from its rescue point (kept `{re_.get('keeps', '?')}`; "
            f"lost {lost}; {re_.get('refill_episodes', '?')} episodes collected before "
            f"the next update) by the binary of commit `{str(binary.get('commit') or '?')[:10]}`."
        )
    return "".join(out)


def load_lost(lost_dir):
    """Records of earlier runs whose home was lost (moved aside by `record`)."""
    if not lost_dir.is_dir():
        return []
    out = []
    for d in sorted(p for p in lost_dir.iterdir() if p.is_dir()):
        env = keeper_env(d / "keeper.env")
        metrics = read_metrics(d / "metrics.csv")
        snaps = []
        for p in sorted((d / "snapshots").glob("epoch-*.test.json")):
            k = int(p.name.split(".")[0].split("-")[1])
            snaps.append((k, read_eval(p, training_threshold(d / "config.toml"))))
        found = keeper_env(d / "lost.env").get("FOUND")
        out.append({"dir": d.name, "env": env, "metrics": metrics, "snapshots": snaps, "found": found})
    return out


def lost_runs(lost, records_rel, rel=None):
    """The lines that say which earlier runs were lost, how far they got and where their record is
    (`rel`: their directory, by default `records_rel` + `_lost`)."""
    if not lost:
        return []
    rel = rel or records_rel.rstrip("/") + "_lost"
    lines = ["", "Earlier runs of these configurations, lost with their machine between two sessions and started "
             "again (their records are kept as they were):", ""]
    for r in lost:
        m = r["metrics"]
        last = m[-1] if m else None
        snaps = ", ".join(f"epoch {k}: {pct(t['interval']) if t else 'n/a'}" for k, t in r["snapshots"])
        lines.append(
            f"- [`{r['dir']}`]({rel}/{r['dir']}/): started {r['env'].get('STARTED', '?')}"
            + (f", found lost {r['found']}" if r["found"] else "") + ", "
            f"{len(m)} epochs recorded ({last['env_steps'] if last else 0} env steps"
            + (f", train {float(last['train_success_rate']):.2f}, eval {float(last['success_rate']):.2f}" if last else "")
            + ")" + (f"; test success of its snapshots: {snaps}" if snaps else "") + "."
        )
    return lines


def latest_common_snapshot(runs):
    """The latest snapshot epoch every run has evaluated on the test set, or None."""
    common = set.intersection(*[{k for k, ev in r["snapshots"] if ev["test"]} for r in runs]) if runs else set()
    return max(common, default=None)


def latest_orderings(runs, lost=False, ended=False):
    """The paper's orderings of Table I, and the drops, at the latest snapshot both runs have on the test set (one seed);
    `lost`: the runs were lost before `finish`; `ended`: `finish` has written the final comparison."""
    labels = ("Dense+FMSR+IS", "Dense")
    by_label = {r["label"]: r for r in runs}
    a, b = (by_label.get(label) for label in labels)
    k = latest_common_snapshot([a, b]) if a and b else None
    if k is None:
        return []
    path = lambda r: r["dir"] / "snapshots" / f"epoch-{k:03d}.test.json"
    ta, tb = (json.loads(path(r).read_text()) for r in (a, b))
    if "stability" not in ta or "stability" not in tb:
        return []
    return ["", f"The paper's orderings of Table I, and the drops of its Table II, at snapshot {k}, on the fixed test set "
            f"({long_runs_final.engine_name(ta)}, "
            "the engine the snapshots are evaluated on, each run's own; our values mean ± std "
            "over the episodes; the verdict needs our 95 % interval of the difference to exclude zero). "
            + ("Lost before the end and one seed each: the final comparison, on both engines and with 500 trials for "
               "the drops (`finish`'s), was never run:" if lost else
               "The last snapshot, one seed each: the final comparison, on both engines and with 500 trials for the "
               "drops, is `finish`'s, at the end of this section:" if ended else
               "In progress and one seed each: the final comparison, on both engines and with 500 trials for the drops, "
               "is `finish`'s:"), ""
            ] + long_runs_final.ORDERING_HEADER + long_runs_final.ordering_rows(ta, tb, ta["task"], labels) + [
            long_runs_final.drops_row(ta, tb, ta["task"], labels, f"test, {ta['episodes']}")]


HEADING = long_runs_final.HEADING
# Above the section in a results file the keeper creates.
INTRO = "The long runs of `scripts/long_runs.sh`: the section below is written by its `record` and `finish`."


def anchor(heading):
    """The anchor a Markdown renderer (GitHub's rule) gives a heading."""
    return "".join(c for c in heading.lower() if c.isalnum() or c in " -_").replace(" ", "-")


def lost_note(runs, earlier):
    """The paragraph that says the running pair was lost: when it was found, where each record stops, what went."""
    gone = [r for r in runs if r["lost"]]
    if not gone:
        return []
    found = " and ".join(sorted({r["lost"] for r in gone}))
    stops = " and ".join(f"{r['label']} after {len(r['metrics'])} epochs" for r in gone)
    starts = {r["env"].get("STARTED") for r in earlier}
    nth = {2: "second", 3: "third", 4: "fourth"}.get(len(starts) + 1, f"loss number {len(starts) + 1}")
    before = f" This is the pair's {nth} loss; the earlier runs are listed at the end." if starts else ""
    planned = {r["planned"] for r in gone}
    end = f"{planned.pop()} epochs" if len(planned) == 1 else "the end"
    return [f"**Lost before {end}.** The keeper's home was found gone at {found}: a session began on a "
            "machine that was not kept from the one before, and every checkpoint, replay buffer, snapshot policy and the "
            f"binary went with it.{before} What follows is the record as the last `record` left it: {stops} (the runs "
            "trained on, unrecorded, until their session ended). No policy of these runs exists any more, so nothing more "
            "can be evaluated, and none of it is a result at the paper's budget.", ""]


def section(runs, finals, commit, records_rel, pretrained_rel, lost=(), heading=HEADING, suffix=long_runs_final.SUFFIX,
            lost_rel=None):
    """The section's lines between its markers; `finals` are the runs' final evaluations, or None before `finish`;
    `heading` names the campaign, `suffix` its runs' directories in pretrained/, `lost_rel` its earlier runs' records."""
    lines = [f"## {heading}", ""]
    gone = any(r["lost"] for r in runs)
    configs = [r["env"].get("CONFIG", "?") for r in runs]
    # From each run's config.toml, not its file name: rapier when it names none (the default).
    engines = sorted({long_runs_final.shown(e) for e in
                      (long_runs_final.config_value((r["dir"] / "config.toml").read_text(), "engine", "rapier")
                       for r in runs)})
    lines.append(
        "Issues 37 and 53: both runs at the paper's config ("
        + ", ".join(f"`{c}`" for c in configs)
        + ": 400 epochs of 25 cycles x 8 rollouts x 100 steps = 20k env steps, 25 x 25 gradient steps of 1024 "
        f"samples, seed 0, trained on {' and '.join(engines)}; the goal distance each config.toml names), one core "
        "each (`trainer.threads = 1`, `networks.threads = 1`, which do not change the results), kept across sessions "
        "by `scripts/long_runs.sh` in `$HOME/.local/share/fmsr/long-runs`, with rescue points in `pretrained/`."
        + ("" if gone else
           " Both runs have ended: the final comparison is at the end of this section." if finals else
           " Until both reach 400 epochs this section is progress, not a result.")
    )
    lines.append("")
    lines += lost_note(runs, lost)
    lines.append(f"- Machine: {machine()}; written by `scripts/long_runs.sh` at commit `{commit}`.")
    for r in runs:
        e = r["env"]
        lines.append(
            f"- `{r['name']}`: started {e.get('STARTED', '?')} with the binary of commit `{e.get('COMMIT', '?')[:10]}` "
            f"(`{Path(e.get('BIN', '?')).name}`"
            + (f" since its restore: {e['BIN_NOTE']}" if e.get("BIN_NOTE") else ", kept for the whole run")
            + "); config and metrics in "
            f"[`{records_rel}/{r['name']}/`]({records_rel}/{r['name']}/)." + restarts_note(r)
        )
    lines += ["", "```sh", f"scripts/long_runs.sh start {' '.join(configs)}  # once",
              "scripts/long_runs.sh resume   # first thing every session", "scripts/long_runs.sh status",
              "scripts/long_runs.sh record   # last thing every session: evaluate snapshots, rewrite this section", "```", ""]
    lines.append("Env steps count the training rollouts (20k an epoch) and the epoch's 50 evaluation episodes (5k).")
    lines.append("")
    lines += ["| Run | Epochs | Env steps | Wall time (h, training) | Median s/epoch (last 10) | Driver at record |", "|---|---|---|---|---|---|"]
    driver = lambda r: f"lost (found {r['lost']})" if r["lost"] else "alive" if r["alive"] else "stopped"
    for r in runs:
        m = r["metrics"]
        hours = sum(float(x["seconds"]) for x in m) / 3600
        med = median([float(x["seconds"]) for x in m[-10:]])
        lines.append(
            f"| {r['label']} | {len(m)} / {r['planned']} | {m[-1]['env_steps'] if m else 0} | {hours:.1f} | "
            f"{'n/a' if med is None else f'{med:.0f}'} | {driver(r)} |"
        )
    lines += ["", f"![learning curves]({records_rel}/curves.svg)", ""]
    lines.append(
        "Training success (exploring, at the training threshold 0.1 rad) and eval success (the epoch's 50 "
        "deterministic episodes, gymnasium's flag at 0.1 rad), every 10th epoch and the last:"
    )
    lines.append("")
    header = "| Epoch | Env steps |" + "".join(f" {r['label']} train | {r['label']} eval |" for r in runs)
    lines += [header, "|" + "---|" * (2 + 2 * len(runs))]
    longest = max((len(r["metrics"]) for r in runs), default=0)
    rows = sorted(set(list(range(9, longest, 10)) + ([longest - 1] if longest else [])))
    for i in rows:
        steps = next((r["metrics"][i]["env_steps"] for r in runs if i < len(r["metrics"])), "")
        cells = "".join(
            f" {float(r['metrics'][i]['train_success_rate']):.2f} | {float(r['metrics'][i]['success_rate']):.2f} |"
            if i < len(r["metrics"]) else " | |" for r in runs
        )
        lines.append(f"| {i + 1} | {steps} |{cells}")
    lines += long_runs_restarts.table(runs)
    lines += ["", "Snapshots (epoch counted from 0) on the fixed test set (100 episodes at 0.4 rad; success = turned "
              "and held) and on 100 validation episodes (seeds disjoint from the test set's), each with its 95 % "
              "Wilson interval; the difference is Dense+FMSR+IS minus Dense on the test set (Newcombe's interval):", ""]
    lines += ["| Snapshot |" + "".join(f" {r['label']} test | {r['label']} validation | {r['label']} drops |" for r in runs) + " Difference (test) |",
              "|" + "---|" * (2 + 3 * len(runs))]
    epochs = sorted({k for r in runs for k, _ in r["snapshots"]})
    for k in epochs:
        cells = ""
        tests = []
        for r in runs:
            ev = dict(r["snapshots"]).get(k)
            t = ev["test"] if ev else None
            v = ev["validation"] if ev else None
            tests.append(t["interval"] if t else None)
            cells += f" {pct(t['interval']) if t else 'n/a'} | {pct(v['interval']) if v else 'n/a'} | {t['drops'] if t else 'n/a'} |"
        diff = pts(difference(tests[0], tests[1])) if len(tests) == 2 and all(tests) else "n/a"
        lines.append(f"| {k} |{cells} {diff} |")
    lines += precision_table(runs, epochs)
    for r in runs:
        best = long_runs_final.best(r["dir"])
        if best is not None:
            t = dict(r["snapshots"])[best]["test"]
            lines.append("")
            when = " when the run was lost" if r["lost"] else "" if finals else " so far"
            lines.append(f"- {r['label']}: the snapshot best on validation{when} is epoch {best}, test success {pct(t['interval']) if t else 'n/a'}.")
    lines += latest_orderings(runs, gone, ended=bool(finals))
    lines += lost_runs(lost, records_rel, lost_rel)
    if finals:
        lines += long_runs_final.section_lines(finals, records_rel, pretrained_rel)
    elif gone:
        lines += ["", "Not run: the final evaluation of issue 37, item 4 (500 episodes, MuJoCo, `fmsr report`, the paper's "
                  "rows): the runs were lost, with their policies, before 400 epochs."]
    else:
        # Runs ended ahead of the other (`finish RUN`): their part is written, the comparison waits.
        ahead = [f"{r['label']} (in [`{records_rel}/{r['dir'].name}/final/`]({records_rel}/{r['dir'].name}/final/) "
                 f"and [`{pretrained_rel}/{r['dir'].name}{suffix}/`]({pretrained_rel}/{r['dir'].name}{suffix}/))"
                 for r in runs if (r["dir"] / "final" / "finished.env").is_file()]
        lines += ["", "Not yet: the final evaluation of issue 37, item 4 (500 episodes, MuJoCo, `fmsr report`, the paper's rows), "
                  "which waits for both runs to reach 400 epochs (`scripts/long_runs.sh finish`)"
                  + (f"; the final evaluations and policies of the runs that have ended are written: {', '.join(ahead)}."
                     if ahead else ".")]
    return "\n".join(lines) + "\n"


def precision_table(runs, epochs):
    """How close the test episodes ended to their goals, per snapshot: what the success rule at 0.4 rad no longer
    tells apart once both runs are near its ceiling. Each run counts the episodes within its own training threshold
    (`within`, from its config.toml); the difference is taken only when the two thresholds agree."""
    rows = []
    within = [r.get("within") for r in runs]
    same = len(set(within)) == 1
    for k in epochs:
        tests = [(dict(r["snapshots"]).get(k) or {}).get("test") for r in runs]
        if not all(t and t["precise"] for t in tests):
            continue
        cells = "".join(f" {angle_cell(t)} | {pct(t['precise'])} |" for t in tests)
        diff = pts(difference(tests[0]["precise"], tests[1]["precise"])) if len(tests) == 2 and same else "n/a"
        rows.append(f"| {k} |{cells} {diff} |")
    if not rows:
        return []
    return ["", f"How close the same test episodes ended to their goals, by the full angle at the last step: the "
            "median final angle (rad; in brackets the medians of its parts, the error about the vertical and the tilt "
            f"from it), and the episodes that ended within {within_label(within)} (the training threshold, "
            "`env.success_threshold`) without a drop, with the difference Dense+FMSR+IS minus Dense (Newcombe's "
            "interval). The success rule at 0.4 rad cannot separate two runs near its ceiling; this is not the "
            "paper's measure:", "",
            "| Snapshot |" + "".join(f" {r['label']} median angle | {r['label']} within {r['within']:g} rad |"
                                     for r in runs)
            + (f" Difference (within {within[0]:g} rad) |" if same else " Difference |"),
            "|" + "---|" * (2 + 2 * len(runs))] + rows


SUMMARY_BEGIN = "<!-- {}-summary:begin (written by scripts/long_runs.sh record) -->"
SUMMARY_END = "<!-- {}-summary:end -->"
PRETRAINED_BEGIN = "<!-- {}-policies:begin (written by scripts/long_runs.sh finish) -->"
PRETRAINED_END = "<!-- {}-policies:end -->"


def summary_bullet(runs, finals, link, heading=HEADING):
    """The line of docs/notebook/results.md's summary on the long runs: how far, and the latest snapshot's test success."""
    if not runs:
        return ""
    if finals:
        return long_runs_final.summary_bullet(finals, link, heading)
    done = min(len(r["metrics"]) for r in runs)
    k = latest_common_snapshot(runs)
    if any(r["lost"] for r in runs):
        if len({r["planned"] for r in runs}) == 1:
            stops = " and ".join(str(len(r["metrics"])) for r in runs) + f" of {runs[0]['planned']}"
        else:
            stops = " and ".join(f"{len(r['metrics'])} of {r['planned']}" for r in runs)
        state = f"lost with their machine; recorded to {stops} epochs"
    else:
        state = f"in progress: {done} of {runs[0]['planned']} epochs"
    name = long_runs_final.lower_first(long_runs_final.short_name(heading))
    text = f"- **Towards {name} ({state}), egg, seed 0:** "
    if k is not None:
        cells = [f"{r['label']} {pct(dict(r['snapshots'])[k]['test']['interval'])} ({dict(r['snapshots'])[k]['test']['drops']} drops)"
                 for r in runs]
        text += f"after {k + 1} epochs, test success " + " against ".join(cells)
        if len(runs) == 2:
            tests = [dict(r["snapshots"])[k]["test"] for r in runs]
            a, b = (t["interval"] for t in tests)
            da, db = (wilson(t["drops"], t["episodes"]) for t in tests)
            text += f"; difference {pts(difference(a, b))}, in drops {pts(difference(da, db))}"
            if all(t["precise"] for t in tests) and tests[0]["within"] == tests[1]["within"]:
                pa, pb = (t["precise"] for t in tests)
                text += (f"; ended within {tests[0]['within']:g} rad of the goal (ours, not the paper's measure: both near the "
                         f"rule's ceiling) {pct(pa)} against {pct(pb)}, {pts(difference(pa, pb))}")
        paper = long_runs_final.PAPER_TABLE1["egg"]
        rates = " against ".join(f"{paper[r['label']][0]} %" for r in runs if r["label"] in paper)
        text += (f". The paper: {rates}; "
                 f"Dense+FMSR+IS drops {long_runs_final.PAPER_TABLE2['egg']['Dense+FMSR+IS'][2]} of 500 trials.")
    else:
        text += "no snapshot evaluated yet."
    return f"{text} Details: [{name}](#{link}).\n"


def replace_between(text, begin, end, new):
    """`text` with what lies between the markers `begin` and `end` (both kept) replaced by `new`; None without them."""
    if begin not in text or end not in text:
        return None
    head, rest = text.split(begin, 1)
    return head + begin + "\n" + new + end + rest.split(end, 1)[1]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--home", type=Path, required=True)
    ap.add_argument("--results", type=Path, required=True)
    ap.add_argument("--records", type=Path, required=True)
    ap.add_argument("--pretrained", type=Path, required=True)
    ap.add_argument("--commit", required=True)
    ap.add_argument("--heading", default=HEADING, help="the campaign's section's heading")
    ap.add_argument("--suffix", default=long_runs_final.SUFFIX, help="of the runs' directories in pretrained/")
    ap.add_argument("--markers", default=None,
                    help="the name in the markers (default: the records directory's, `_` as `-`)")
    a = ap.parse_args()
    markers = a.markers or a.records.name.replace("_", "-")
    begin, end = BEGIN.format(markers), END.format(markers)
    # A run's records hold its keeper.env; `report/` (written by `finish`) is no run.
    found = [p.name for p in a.records.iterdir() if (p / "keeper.env").is_file()]
    names = [n for n in LABELS if n in found] + sorted(n for n in found if n not in LABELS)
    runs = [load_run(a.records, a.home, n) for n in names]
    svg_curves(runs, a.records / "curves.svg")
    rel = os.path.relpath(a.records, a.results.parent)
    pretrained_rel = os.path.relpath(a.pretrained, a.results.parent)
    # A campaign's own results file starts as one line above the section.
    text = a.results.read_text() if a.results.exists() else f"{INTRO}\n"
    lost_dir = a.records.parent / (a.records.name + "_lost")
    lost = load_lost(lost_dir)
    # The final evaluations, once `finish` wrote them for every run.
    finals = [long_runs_final.load_final(r["dir"]) for r in runs]
    finals = finals if finals and all(finals) else None
    new = section(runs, finals, a.commit, rel, pretrained_rel, lost, a.heading, a.suffix,
                  os.path.relpath(lost_dir, a.results.parent))
    text = replace_between(text, begin, end, new) or f"{text.rstrip()}\n\n{begin}\n{new}{end}\n"
    text = replace_between(text, SUMMARY_BEGIN.format(markers), SUMMARY_END.format(markers),
                           summary_bullet(runs, finals, anchor(a.heading), a.heading)) or text
    write_atomic(a.results, text)
    print(f"wrote the section into {a.results} and {a.records / 'curves.svg'}")
    index = a.pretrained / "README.md"
    if index.exists() and finals:
        new_index = replace_between(index.read_text(), PRETRAINED_BEGIN.format(markers), PRETRAINED_END.format(markers),
                                    long_runs_final.pretrained_index(finals, a.suffix, a.heading))
        if new_index is not None:
            write_atomic(index, new_index)
            print(f"wrote the long runs' policies into {index}")


if __name__ == "__main__":
    main()
