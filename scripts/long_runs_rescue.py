#!/usr/bin/env python3
"""When `scripts/long_runs.sh record` (re)writes a run's rescue point in pretrained/.

Every rescue point written there ends up in git's history (each one a few MB),
so `record` does not write one at every call. It writes a run's rescue point
only when the run is still training (it has not trained all its planned
epochs: an ended one waits for `finish`, which removes it), and either

- the run has none in pretrained/ yet (or the one there is not this run's: an
  earlier run of the same name, or ahead of the epochs this one has trained),
- or the one there is at least `every` seconds of training old: the `seconds`
  of the epochs the run trained after the rescue point's EPOCH (its rescue.env;
  metrics.csv counts epochs from 0, EPOCH counts the epochs trained, so the
  epochs after it are those numbered EPOCH and up) add up to `every` or more,
- or it was written at least `age` seconds ago by the clock (its WRITTEN;
  default 20 h: about a day, as sessions do not start at the same hour) and
  the run has trained at least `floor` seconds after it (default 1 h).

The clock's day is there because training only runs while a session does
(about 3 h of a day) and the home has been lost between sessions about once a
day: measured on the paper-stack pair, three homes lost in three days, each
after 3 to 8.5 h of training past the rescue point, so a rescue point rewritten
only after 24 h of training was never rewritten and the runs went back to
epoch 4 each time. At most one rewrite a run a day keeps the history's growth
to about 4 MB a run a day while a loss costs at most a day's training.

Otherwise the rescue point there stays as it is; `record` says so in one line.

    long_runs_rescue.py due --metrics RUN/metrics.csv --rescue PRETRAINED/<run><suffix>/rescue \
        --every SECONDS [--age SECONDS] [--floor SECONDS] [--now ISO] [--started STARTED] [--finished]

prints `write: <why>` or `skip: <why>` (one line) and exits 0; anything else is
an error. Tested by scripts/test_long_runs_rescue.py.
"""

import argparse
import csv
import sys
from datetime import datetime, timezone
from pathlib import Path

from long_runs_record import keeper_env

# Seconds of training between two rescue points of a run: about a day.
EVERY = 86400
# Seconds by the clock after which a rescue point is rewritten when the run has trained `FLOOR` seconds since:
# about a day (20 h, so that a session that starts a little earlier than yesterday's still rewrites it).
AGE = 72000
FLOOR = 3600


# rescue.env is read as the keeper's env files are (KEY=VALUE, quotes dropped).
read_env = keeper_env


def seconds_since(rows, epoch):
    """The seconds of training of the metrics.csv `rows` after a rescue point of `epoch` epochs trained."""
    return sum(float(r["seconds"]) for r in rows if int(r["epoch"]) >= epoch)


def hours(seconds):
    return f"{seconds / 3600:.1f} h"


def parse_time(text):
    """A WRITTEN or --now time (`2026-12-03T10:35:01Z`, as `date -u +%FT%TZ` writes it), timezone-aware; None if
    it is not one."""
    try:
        t = datetime.fromisoformat(text.replace("Z", "+00:00"))
    except (AttributeError, ValueError):
        return None
    return t if t.tzinfo else None


def due(rows, rescue_epoch, every=EVERY, finished=False, written=None, now=None, age=AGE, floor=FLOOR):
    """Whether to (re)write a run's rescue point, and why: (True, why) to write, (False, why) to leave it.

    `rows`: the run's metrics.csv rows (dicts with `epoch`, from 0, and `seconds`); `rescue_epoch`: the EPOCH of
    the rescue point in pretrained/ (epochs trained when it was written), None when there is none (or it is not
    this run's); `every`: seconds of training after which it is rewritten; `finished`: the run has trained all
    its planned epochs; `written`, `now`: when the rescue point was written and the time now (aware datetimes;
    `written` None when unknown, then only the training counts); `age`, `floor`: seconds by the clock after which
    it is rewritten if the run trained `floor` seconds or more since it."""
    if finished:
        return False, "has trained all its epochs: no new rescue point (`finish` ends it)"
    if rescue_epoch is None:
        return True, "no rescue point in pretrained/ yet"
    if rescue_epoch > len(rows):
        return True, f"the rescue point (epoch {rescue_epoch}) is ahead of the run's {len(rows)} epochs: not this run's"
    since = seconds_since(rows, rescue_epoch)
    if since >= every:
        return True, f"{hours(since)} of training since the rescue point of epoch {rescue_epoch}"
    old = (now - written).total_seconds() if written is not None and now is not None else None
    if old is not None and old >= age and since >= floor:
        return True, (f"the rescue point of epoch {rescue_epoch} was written {hours(old)} ago, "
                      f"{hours(since)} of training since it")
    when = f", written {hours(old)} ago" if old is not None else ""
    return False, (f"rescue point of epoch {rescue_epoch} kept: {hours(since)} of training since it{when}, "
                   f"rewritten after {hours(every)} of training, or {hours(age)} by the clock "
                   f"with {hours(floor)} of training")


def read_metrics(path):
    if not path.is_file():
        return []
    with path.open(newline="") as f:
        return list(csv.DictReader(f))


def rescue_point(rescue):
    """The rescue.env of the rescue point in directory `rescue`, None when it has no rescue.fmsr or no EPOCH."""
    env = read_env(rescue / "rescue.env")
    return env if (rescue / "rescue.fmsr").is_file() and "EPOCH" in env else None


def main():
    ap = argparse.ArgumentParser()
    sub = ap.add_subparsers(dest="cmd", required=True)
    d = sub.add_parser("due")
    d.add_argument("--metrics", type=Path, required=True)
    d.add_argument("--rescue", type=Path, required=True)
    d.add_argument("--every", type=float, default=EVERY)
    d.add_argument("--age", type=float, default=AGE)
    d.add_argument("--floor", type=float, default=FLOOR)
    d.add_argument("--now", default=None, help="the time now (default: the clock), as WRITTEN is written")
    d.add_argument("--started", default=None)
    d.add_argument("--finished", action="store_true")
    a = ap.parse_args()
    now = parse_time(a.now) if a.now else datetime.now(timezone.utc)
    if now is None:
        ap.error(f"--now {a.now!r} is not a time such as 2026-12-03T10:35:01Z")
    env = rescue_point(a.rescue)
    if env and a.started and env.get("STARTED") and env["STARTED"] != a.started and not a.finished:
        # An earlier run of the same name left it (rescue.env names the STARTED of the run it is of).
        write, why = True, f"the rescue point in pretrained/ is an earlier run's (started {env['STARTED']})"
    else:
        written = parse_time(env.get("WRITTEN")) if env else None
        write, why = due(read_metrics(a.metrics), int(env["EPOCH"]) if env else None, a.every, a.finished,
                         written, now, a.age, a.floor)
    print(f"{'write' if write else 'skip'}: {why}")


if __name__ == "__main__":
    sys.exit(main())
