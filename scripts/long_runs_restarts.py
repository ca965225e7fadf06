"""What a restart from a rescue point cost a long run, from its own metrics.csv.

A run restored from its rescue point (issue 53) lost its replay buffer and
collected `refill_episodes` before its next update. No twin of the run goes on
uninterrupted, so the cost is read off the run itself: the success over the
`WINDOW` epochs before the restart against the `WINDOW` epochs after it, pooled,
for the epoch's deterministic evaluation (`success_rate`, `trainer.eval_episodes`
an epoch) and for the exploring training rollouts (`train_success_rate`,
`trainer.cycles` x `trainer.episodes_per_cycle` an epoch).

Two yardsticks, since neither alone is fair:

- Newcombe's interval of the difference treats the pooled episodes as one
  binomial sample, which they are not (ten policies, and a learning trend);
- the reference: the same difference at every other epoch boundary within
  `SPAN` epochs of the restart whose two windows hold no restart, the spread
  a boundary without a restart shows in this run at this stage (overlapping
  windows, so not independent draws). A restart whose difference lies inside
  that spread cost nothing this measure can see.

Epochs are metrics.csv's `epoch` column (counted from 0); a restart "at epoch
E" is one from the rescue point written after E epochs, so epoch E is the first
it trains.
"""

import tomllib

from long_runs_final import newcombe, pct, pts, wilson

WINDOW = 10
SPAN = 50


def episodes_per_epoch(config_path):
    """(eval episodes, training episodes) an epoch of a run's config.toml, else None where it does not say."""
    try:
        t = tomllib.loads(config_path.read_text())["trainer"]
        return int(t["eval_episodes"]), int(t["cycles"]) * int(t["episodes_per_cycle"])
    except (OSError, KeyError, TypeError, ValueError, tomllib.TOMLDecodeError):
        return None


def successes(metrics, column, n):
    """{epoch: successes} of `column` (a rate over `n` episodes an epoch) in metrics.csv's rows."""
    out = {}
    for row in metrics:
        try:
            out[int(row["epoch"])] = round(float(row[column]) * n)
        except (KeyError, TypeError, ValueError):
            continue
    return out


def pooled(counts, n, lo, hi):
    """(successes, episodes) over epochs lo..hi-1, None unless every one of them is in `counts`."""
    if lo < 0 or any(e not in counts for e in range(lo, hi)):
        return None
    return sum(counts[e] for e in range(lo, hi)), n * (hi - lo)


def window_difference(counts, n, boundary, window=WINDOW):
    """Success over the `window` epochs from `boundary` minus that over the `window` before it, as rates."""
    before = pooled(counts, n, boundary - window, boundary)
    after = pooled(counts, n, boundary, boundary + window)
    if before is None or after is None:
        return None
    return after[0] / after[1] - before[0] / before[1]


def restart_cost(counts, n, epoch, restarts, window=WINDOW, span=SPAN):
    """The restart at `epoch`'s before and after (Wilson intervals), their difference (Newcombe's interval) and the
    reference spread (min, max, boundaries) of the other boundaries within `span` epochs whose windows hold no
    restart of `restarts` (their epochs) or `epoch`; None until the windows on both sides are trained."""
    before = pooled(counts, n, epoch - window, epoch)
    after = pooled(counts, n, epoch, epoch + window)
    if before is None or after is None:
        return None
    a, b = wilson(*after), wilson(*before)
    reference, held = [], set(restarts) | {epoch}
    for k in range(epoch - span, epoch + span + 1):
        if any(k - window < r < k + window for r in held):
            continue
        d = window_difference(counts, n, k, window)
        if d is not None:
            reference.append(d)
    spread = (min(reference), max(reference), len(reference)) if reference else None
    return {"before": b, "after": a, "difference": newcombe(a, b), "spread": spread}


def verdict(cost):
    """Where the restart's difference lies against the reference spread."""
    s = cost["spread"]
    if s is None:
        return "no reference yet"
    d = cost["difference"][0]
    return "below the spread" if d < s[0] else "above the spread" if d > s[1] else "within the spread"


def table(runs, window=WINDOW, span=SPAN):
    """The lines of the table of every restart of `runs` (each with `label`, `metrics`, `restarts`, `per_epoch`:
    episodes_per_epoch's pair or None), eval and training success; [] when no run restarted."""
    rows = []
    for r in runs:
        epochs = [x.get("restart", {}).get("epoch") for x in r.get("restarts", [])]
        epochs = [e for e in epochs if isinstance(e, int)]
        # Restarts at one epoch (a home lost again before the next rescue point) read the same records: one row.
        for e in sorted(set(epochs)):
            times = epochs.count(e)
            cells = []
            for column, n in zip(("success_rate", "train_success_rate"), r.get("per_epoch") or (None, None)):
                cost = None if n is None else restart_cost(successes(r["metrics"], column, n), n, e, epochs,
                                                           window, span)
                if cost is None:
                    cells.append("n/a | n/a | n/a | n/a")
                    continue
                s = cost["spread"]
                d = 100 * cost["difference"][0]
                ref = "none" if s is None else (f"{d:+.1f} against {100 * s[0]:+.1f} to {100 * s[1]:+.1f} pts ({s[2]}): "
                                               f"{verdict(cost)}")
                cells.append(f"{pct(cost['before'])} | {pct(cost['after'])} | {pts(cost['difference'])} | {ref}")
            at = f"{e} ({times} times)" if times > 1 else f"{e}"
            rows.append(f"| {r['label']} | {at} | " + " | ".join(cells) + " |")
    if not rows:
        return []
    return ["", f"What each restart from a rescue point cost, read off the run itself (no twin goes on uninterrupted): "
            f"success over the {window} epochs before the restart against the {window} after it, pooled (eval: the "
            f"epochs' deterministic episodes at 0.1 rad; train: the exploring rollouts), with Newcombe's interval of "
            f"the difference (which takes the pooled episodes for one binomial sample: they are not), and beside it "
            f"the same difference at every other epoch boundary within {span} epochs whose windows hold no restart "
            "(the spread without a restart, in points to one decimal beside the restart's own; overlapping windows, how "
            "many in brackets). n/a where fewer than "
            f"{window} epochs lie on either side of the restart (before it, or trained since):", "",
            "| Run | Restart at epoch | Eval before | Eval after | Eval difference | Eval without a restart "
            "| Train before | Train after | Train difference | Train without a restart |",
            "|---|---|---|---|---|---|---|---|---|---|"] + rows
