#!/usr/bin/env python3
"""Regression test: the long runs' results name the engine each evaluation ran on.

Guards bd28d19's fix: the pair trains on MuJoCo and its snapshots are
evaluated there, but the in-progress orderings were labelled "rapier" and
`finish` put the best snapshot's test evaluation in the rapier rows. And the
fix of 2026-11-29: `finish`'s summary line, policy index and READMEs took
the rapier evaluations as the trained-on ones, and read env_steps from the
fifth column of metrics.csv (train_success_rate since 2026-11-27). Uses the
pair's own MuJoCo snapshot evaluations and metrics from
docs/results/paper_budget, as final evaluations named by their engine.
Runs in a second (CI's `long-runs-engines` stage); no build needed.
"""

import re
import shutil
import sys
import tempfile
from pathlib import Path

root = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(root / "scripts"))
import long_runs_final  # noqa: E402
import long_runs_record  # noqa: E402

SNAP = "epoch-024.test.json"


def fixture(run):
    """The run's MuJoCo snapshot evaluation, in its record or, once archived, a lost one's."""
    for p in sorted((root / "docs/results").glob(f"paper_budget*/{run}*/snapshots/{SNAP}")):
        if p.parent.parent.name in (run,) or p.parent.parent.name.startswith(run + "-"):
            if long_runs_final.read_json(p).get("engine") == "mujoco":
                return p
    sys.exit(f"test_long_runs_engines: no MuJoCo {SNAP} of {run} under docs/results/paper_budget*")


mujoco = {run: fixture(run) for run in ("egg_dense_fmsr_is", "egg_dense")}

# The best snapshot lands in the rows of the engine it was evaluated on, only.
e = long_runs_final.read_json(mujoco["egg_dense"])
assert long_runs_final.engine_of(e) == "mujoco", e.get("engine")
r = {"best_test": e}
assert long_runs_final.best_on(r, "mujoco") is e
assert long_runs_final.best_on(r, "rapier") is None, "a MuJoCo evaluation in the rapier rows"
assert long_runs_final.best_on({"best_test": None}, "rapier") is None
# An evaluation written before the field existed was on rapier.
assert long_runs_final.engine_of({}) == "rapier"
assert long_runs_final.engine_name(e) == "MuJoCo"
assert long_runs_final.trained_on([{"engine": "mujoco"}]) == "MuJoCo"
# The engine a config names, top level only; rapier (the default) when it names none.
cfg = 'engine = "mujoco"  # a comment\nmethod = "dense"\n\n[env]\nengine = "rapier"\n'
assert long_runs_final.config_value(cfg, "engine") == "mujoco"
assert long_runs_final.config_value(cfg, "method") == "dense"
assert long_runs_final.config_value('method = "dense"\n[env]\nengine = "mujoco"\n', "engine", "rapier") == "rapier"

# The in-progress orderings name MuJoCo for MuJoCo evaluations.
with tempfile.TemporaryDirectory() as tmp:
    runs = []
    for run, label in (("egg_dense_fmsr_is", "Dense+FMSR+IS"), ("egg_dense", "Dense")):
        d = Path(tmp, run)
        (d / "snapshots").mkdir(parents=True)
        shutil.copyfile(mujoco[run], d / "snapshots" / SNAP)
        runs.append({"label": label, "dir": d, "snapshots": [(24, {"test": True})]})
    lines = long_runs_record.latest_orderings(runs)
    heading = next(line for line in lines if line.startswith("The paper's orderings"))
    assert "fixed test set (MuJoCo," in heading, heading
    assert "rapier" not in heading.split("(", 1)[1].split(";", 1)[0], heading

# `finish`'s Python on a MuJoCo-trained pair: final evaluations named by set
# and engine (the snapshot's, relabelled on rapier), as `finish` writes them.
with tempfile.TemporaryDirectory() as tmp:
    finals = []
    for run in ("egg_dense_fmsr_is", "egg_dense"):
        src = mujoco[run].parent.parent
        d = Path(tmp, run)
        shutil.copytree(src / "snapshots", d / "snapshots")
        for f in ("config.toml", "metrics.csv", "keeper.env"):
            shutil.copyfile(src / f, d / f)
        (d / "final").mkdir()
        for name in long_runs_final.FINALS:
            kind, engine = name.split("-")
            e = dict(long_runs_final.read_json(d / "snapshots" / SNAP.replace("test", "validation" if kind == "validation" else "test")))
            e["engine"] = engine
            (d / "final" / f"{name}.json").write_text(long_runs_final.json.dumps(e))
        f = long_runs_final.load_final(d)
        assert f["engine"] == "mujoco", f["engine"]
        last = (src / "metrics.csv").read_text().splitlines()
        assert f["epochs"] == len(last) - 1, f["epochs"]
        col = last[0].split(",").index("env_steps")
        assert f["env_steps"] == int(last[-1].split(",")[col]), (f["env_steps"], last[-1])
        finals.append(f)
        out = Path(tmp, run + "_paper")
        out.mkdir()
        long_runs_final.readme(d, out, "abc")
        text = (out / "README.md").read_text()
        # The rows after the table's header rule, however many columns it has.
        table = re.split(r"^\|(?:---\|)+$", text, maxsplit=1, flags=re.M)[1].strip().splitlines()
        assert table[0].startswith("| fixed test set, MuJoCo (trained on) |"), table[0]
        assert "trained on MuJoCo" in text and "--features mujoco -- eval" in text
    # Every final evaluation, with MuJoCo's rows first.
    assert set(long_runs_final.FINALS) >= {"validation-mujoco", "validation-rapier"}
    lines = long_runs_final.section_lines(finals, "R", "P")
    heads = [line for line in lines if line.startswith("**Against the paper's own values")]
    assert [h.split("**")[1].split(", ")[-1] for h in heads] == ["MuJoCo", "rapier"], heads
    bullet = long_runs_final.summary_bullet(finals, "x")
    assert "on the fixed test set on MuJoCo (the engine they trained on)" in bullet, bullet
    index = long_runs_final.pretrained_index(finals)
    assert "| Dense, 6 agents | " + str(finals[1]["epochs"]) + " | MuJoCo |" in index, index

print("test_long_runs_engines: passed")
