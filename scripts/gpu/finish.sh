#!/usr/bin/env bash
# Step 4 of 4, on the GPU machine: stops each run if it is still training (it
# keeps its last complete epoch), evaluates it on the fixed test set (and on
# MuJoCo when the pack holds it), renders test episode 0, writes one report
# over the runs (with the renderings), exports each policy, and puts into
# OUT_DIR what comes back:
# runs.tar.gz (the report, and per run config.toml, provenance.json,
# metrics.csv/jsonl, eval*.json, the log and REACHED, which
# says how many of the planned epochs it trained) and one NAME.fmsr per run
# that completed an epoch (one that did not is skipped, its log kept):
# 1 + N files, so at most 7 runs for the 8 files a GPU machine gives back.
#
#   scripts/gpu/finish.sh "$OUT" block_dense_fmsr_is block_dense
set -euo pipefail
cd "$(dirname "$0")/../.."
if [ $# -lt 2 ]; then
  echo "usage: $0 OUT_DIR NAME..." >&2
  exit 2
fi
out=$1
shift
if [ $# -gt 7 ]; then
  echo "at most 7 runs (8 files come back: the archive and one policy per run)" >&2
  exit 2
fi
# shellcheck source=scripts/gpu/env.sh
. scripts/gpu/env.sh
mkdir -p "$out"
runs=()
for name in "$@"; do
  run=runs/gpu/$name
  if [ -f "$run.pid" ] && kill -0 "$(cat "$run.pid")" 2>/dev/null; then
    kill -TERM "$(cat "$run.pid")"
    while kill -0 "$(cat "$run.pid")" 2>/dev/null; do sleep 1; done
  fi
  planned=$(sed -n 's/^epochs = \([0-9]*\)$/\1/p' "$run/config.toml" | head -n 1)
  reached=$(( $(wc -l < "$run/metrics.csv") - 1 ))
  if [ "$reached" -lt "$planned" ]; then
    echo "$name: trained $reached of $planned epochs (stopped before the end: not a full run)" | tee "$run/REACHED"
  else
    echo "$name: trained all $planned epochs" | tee "$run/REACHED"
  fi
  if [ ! -f "$run/checkpoint.bin" ]; then
    echo "$name: no epoch complete, nothing to evaluate"
    continue
  fi
  "$FMSR" eval "$run" | tail -n 3
  if [ -d "${FMSR_PACK:-.gpu}/lib" ]; then
    "$FMSR" eval "$run" --engine mujoco | tail -n 3
  fi
  "$FMSR" render "$run" --episode 0
  "$FMSR" export "$run" --out "$out/$name.fmsr"
  runs+=("$run")
done
files=()
if [ ${#runs[@]} -gt 0 ]; then
  "$FMSR" report "${runs[@]}" --out runs/gpu/report
  files+=(report)
fi
for name in "$@"; do
  for f in config.toml provenance.json metrics.csv metrics.jsonl REACHED eval*.json; do
    for g in runs/gpu/"$name"/$f; do
      if [ -f "$g" ]; then files+=("$name/$(basename "$g")"); fi
    done
  done
  files+=("$name.log")
done
tar czf "$out/runs.tar.gz" -C runs/gpu "${files[@]}"
ls -l "$out"
