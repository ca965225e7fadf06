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
  epochs after it are those numbered EPOCH and up) add up to `every` or more.

Otherwise the rescue point there stays as it is; `record` says so in one line.

    long_runs_rescue.py due --metrics RUN/metrics.csv --rescue PRETRAINED/<run><suffix>/rescue \
        --every SECONDS [--started STARTED] [--finished]

prints `write: <why>` or `skip: <why>` (one line) and exits 0; anything else is
an error. Tested by scripts/test_long_runs_rescue.py.
"""

import argparse
import csv
import sys
from pathlib import Path

from long_runs_record import keeper_env

# Seconds of training between two rescue points of a run: about a day.
EVERY = 86400


# rescue.env is read as the keeper's env files are (KEY=VALUE, quotes dropped).
read_env = keeper_env


def seconds_since(rows, epoch):
    """The seconds of training of the metrics.csv `rows` after a rescue point of `epoch` epochs trained."""
    return sum(float(r["seconds"]) for r in rows if int(r["epoch"]) >= epoch)


def hours(seconds):
    return f"{seconds / 3600:.1f} h"


def due(rows, rescue_epoch, every=EVERY, finished=False):
    """Whether to (re)write a run's rescue point, and why: (True, why) to write, (False, why) to leave it.

    `rows`: the run's metrics.csv rows (dicts with `epoch`, from 0, and `seconds`); `rescue_epoch`: the EPOCH of
    the rescue point in pretrained/ (epochs trained when it was written), None when there is none (or it is not
    this run's); `every`: seconds of training after which it is rewritten; `finished`: the run has trained all
    its planned epochs."""
    if finished:
        return False, "has trained all its epochs: no new rescue point (`finish` ends it)"
    if rescue_epoch is None:
        return True, "no rescue point in pretrained/ yet"
    if rescue_epoch > len(rows):
        return True, f"the rescue point (epoch {rescue_epoch}) is ahead of the run's {len(rows)} epochs: not this run's"
    since = seconds_since(rows, rescue_epoch)
    if since >= every:
        return True, f"{hours(since)} of training since the rescue point of epoch {rescue_epoch}"
    return False, (f"rescue point of epoch {rescue_epoch} kept: {hours(since)} of training since it, "
                   f"rewritten after {hours(every)}")


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
    d.add_argument("--started", default=None)
    d.add_argument("--finished", action="store_true")
    a = ap.parse_args()
    env = rescue_point(a.rescue)
    if env and a.started and env.get("STARTED") and env["STARTED"] != a.started and not a.finished:
        # An earlier run of the same name left it (rescue.env names the STARTED of the run it is of).
        write, why = True, f"the rescue point in pretrained/ is an earlier run's (started {env['STARTED']})"
    else:
        write, why = due(read_metrics(a.metrics), int(env["EPOCH"]) if env else None, a.every, a.finished)
    print(f"{'write' if write else 'skip'}: {why}")


if __name__ == "__main__":
    sys.exit(main())
