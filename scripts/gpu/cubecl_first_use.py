#!/usr/bin/env python3
"""Where a first use of a GPU device went, from cubecl's debug log.

A log written with CUBECL_DEBUG_LOG=FILE (scripts/gpu/lease.sh's
FMSR_LEASE_CUBECL_LOG=1) holds, in order, one block per kernel that cubecl
compiled (from [START_KERNEL_COMPILATION], its `name:`, to
[END_KERNEL_COMPILATION]) and one row per profiled launch
(`| 1.234ms | Name_hash`). This prints, per kernel family: kernels compiled,
launches profiled, their total time, and the time of the launches above a
threshold (default 0.1 s), which on a fresh device are the first launch of
each compiled kernel: autotune tries each candidate once it is compiled.

    scripts/gpu/cubecl_first_use.py cubecl.log [--slow SECONDS]
    xz -dc cubecl.log.xz | scripts/gpu/cubecl_first_use.py -
"""
import argparse
import collections
import re
import sys

ROW = re.compile(r"^\|\s*([0-9.]+)(ns|µs|us|ms|s)\s*\|\s*(\S+)")
UNIT = {"ns": 1e-9, "µs": 1e-6, "us": 1e-6, "ms": 1e-3, "s": 1.0}


def family(name):
    """`cubek_matmul::...::MatmulEntry<...` and `MatmulEntry_1a2b3c4d` both give `MatmulEntry`."""
    name = name.split("<", 1)[0].rsplit("::", 1)[-1]
    return re.sub(r"_[0-9a-f]{8}$", "", name)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("log", help="cubecl's debug log, or - for standard input")
    parser.add_argument("--slow", type=float, default=0.1, help="a slow launch, in seconds (default 0.1)")
    args = parser.parse_args()
    source = sys.stdin if args.log == "-" else open(args.log, encoding="utf-8", errors="replace")
    compiled = collections.Counter()
    launches = collections.Counter()
    seconds = collections.Counter()
    slow = collections.Counter()
    slow_seconds = collections.Counter()
    in_kernel = False
    for line in source:
        if line.startswith("[START_KERNEL_COMPILATION]"):
            in_kernel = True
        elif line.startswith("[END_KERNEL_COMPILATION]"):
            in_kernel = False
        elif in_kernel and line.startswith("name: "):
            compiled[family(line[6:].strip())] += 1
        elif not in_kernel:
            m = ROW.match(line)
            if m:
                k, t = family(m.group(3)), float(m.group(1)) * UNIT[m.group(2)]
                launches[k] += 1
                seconds[k] += t
                if t > args.slow:
                    slow[k] += 1
                    slow_seconds[k] += t
    if not compiled and not launches:
        sys.exit(f"{args.log}: no kernel compilation and no profiled launch (not a CUBECL_DEBUG_LOG file?)")
    print(f"{'kernel family':<28} {'compiled':>8} {'launches':>9} {'seconds':>9} {f'> {args.slow:g} s':>9} {'seconds':>9}")
    for k in sorted(set(compiled) | set(launches), key=lambda k: -seconds[k]):
        print(f"{k:<28} {compiled[k]:>8} {launches[k]:>9} {seconds[k]:>9.3f} {slow[k]:>9} {slow_seconds[k]:>9.3f}")
    print(
        f"{'all':<28} {sum(compiled.values()):>8} {sum(launches.values()):>9} {sum(seconds.values()):>9.3f}"
        f" {sum(slow.values()):>9} {sum(slow_seconds.values()):>9.3f}"
    )


if __name__ == "__main__":
    main()
