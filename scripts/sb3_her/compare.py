"""Sets the stable-baselines3 peer beside fmsr's single-agent reference, epoch
by epoch, as the markdown tables of docs/notebook/results.md (issue 11, item 6).

    python3 scripts/sb3_her/compare.py runs/peer/sb3_her_s0 runs/peer/fmsr_single_mujoco_s0

Both runs do the same work per epoch: 10k training env steps, 2000 gradient
steps of 256 and 10 deterministic test episodes whose success is measured at
0.1 rad (SB3: `success_rate`, `train_success_rate`, `epoch_seconds`; fmsr:
`success_rate`, `train_success_rate`, `seconds`). Needs only the standard library.
"""

import argparse
import csv
import os
import statistics
import sys

TRAIN_STEPS_PER_EPOCH = 10_000


def load(run, columns):
    path = os.path.join(run, "metrics.csv")
    try:
        with open(path, newline="") as f:
            rows = list(csv.DictReader(f))
    except OSError as e:
        sys.exit(f"cannot read {path}: {e}")
    missing = [c for c in columns.values() if rows and c not in rows[0]]
    if not rows or missing:
        sys.exit(f"{path}: no rows, or missing columns {missing}")
    return [{k: float(r[c]) for k, c in columns.items()} | {"epoch": int(r["epoch"])} for r in rows]


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("sb3", help="the SB3 run directory (scripts/sb3_her/train.py --out)")
    p.add_argument("fmsr", help="the fmsr run directory (fmsr train --out)")
    p.add_argument("--every", type=int, default=5, help="print every K-th epoch (and the last)")
    p.add_argument("--last", type=int, default=10, help="epochs averaged at the end")
    args = p.parse_args()
    cols = {"test": "success_rate", "train": "train_success_rate"}
    sb3 = load(args.sb3, cols | {"secs": "epoch_seconds"})
    ours = load(args.fmsr, cols | {"secs": "seconds"})
    n = min(len(sb3), len(ours))
    if n == 0 or args.every < 1 or args.last < 1:
        sys.exit("nothing to compare")

    print("| Epoch | Training env steps | SB3 test | SB3 train | fmsr test | fmsr train | SB3 s/epoch | fmsr s/epoch |")
    print("|---|---|---|---|---|---|---|---|")
    for e in range(n):
        if e % args.every == args.every - 1 or e == 0 or e == n - 1:
            a, b = sb3[e], ours[e]
            steps = (e + 1) * TRAIN_STEPS_PER_EPOCH
            print(
                f"| {e} | {steps // 1000}k | {a['test']:.2f} | {a['train']:.2f} | {b['test']:.2f} | {b['train']:.2f} "
                f"| {a['secs']:.1f} | {b['secs']:.1f} |"
            )

    last = slice(max(0, n - args.last), n)
    mean = lambda rows, k: statistics.fmean(r[k] for r in rows[last])  # noqa: E731
    total = lambda rows: sum(r["secs"] for r in rows[:n])  # noqa: E731
    first_at = lambda rows, k, level: next((r["epoch"] for r in rows[:n] if r[k] >= level), None)  # noqa: E731
    print()
    print("| | SB3 HER + DDPG | fmsr single agent |")
    print("|---|---|---|")
    print(f"| epochs compared | {n} | {n} |")
    print(f"| mean test success, epochs {last.start}-{n - 1} | {mean(sb3, 'test'):.3f} | {mean(ours, 'test'):.3f} |")
    print(f"| mean train success, epochs {last.start}-{n - 1} | {mean(sb3, 'train'):.3f} | {mean(ours, 'train'):.3f} |")
    for level in (0.1, 0.3):
        fa, fb = first_at(sb3, "train", level), first_at(ours, "train", level)
        show = lambda e: "never" if e is None else f"epoch {e} ({(e + 1) * TRAIN_STEPS_PER_EPOCH // 1000}k steps)"  # noqa: E731
        print(f"| first epoch with train success >= {level} | {show(fa)} | {show(fb)} |")
    ta, tb = total(sb3), total(ours)
    print(f"| wall time, all {n} epochs | {ta / 60:.1f} min | {tb / 60:.1f} min |")
    steps = n * TRAIN_STEPS_PER_EPOCH
    print(f"| wall time per training env step | {1e3 * ta / steps:.2f} ms | {1e3 * tb / steps:.2f} ms |")
    print(f"\nfmsr / SB3 wall time: {tb / ta:.2f}")


if __name__ == "__main__":
    main()
