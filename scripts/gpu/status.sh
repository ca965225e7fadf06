#!/usr/bin/env bash
# Step 3 of 4, on the GPU machine: per run, whether it is still training, the
# epochs done of those planned, and the last epochs of its metrics.csv.
#
#   scripts/gpu/status.sh [NAME...]     # default: every run under runs/gpu/
set -euo pipefail
cd "$(dirname "$0")/../.."
names=("$@")
if [ ${#names[@]} -eq 0 ]; then
  for d in runs/gpu/*/; do [ -d "$d" ] && names+=("$(basename "$d")"); done
fi
for name in "${names[@]}"; do
  run=runs/gpu/$name
  planned=$(sed -n 's/^epochs = \([0-9]*\)$/\1/p' "$run/config.toml" 2>/dev/null | head -n 1)
  done_=$(( $(wc -l < "$run/metrics.csv" 2>/dev/null || echo 1) - 1 ))
  state=stopped
  if [ -f "$run.pid" ] && kill -0 "$(cat "$run.pid")" 2>/dev/null; then state=training; fi
  echo "== $name: $state, $done_ of ${planned:-?} epochs"
  if [ "$done_" -gt 0 ]; then
    # epoch, eval and train success, env steps, seconds of the epoch
    cut -d, -f1,2,3,5,9 "$run/metrics.csv" | sed -n '1p' | tr ',' '\t'
    tail -n +2 "$run/metrics.csv" | tail -n 3 | cut -d, -f1,2,3,5,9 | tr ',' '\t'
  else
    tail -n 3 "$run.log" 2>/dev/null || true
  fi
done
