#!/usr/bin/env bash
# Test-set success along a training run: waits for each given epoch of a run
# that is training, copies its checkpoint as that epoch left it into
# RUN.snapshots/epoch-KK/ (config.toml, checkpoint.bin, metrics), and runs
# `fmsr eval` on the copy (the fixed test set of the run's config, 100 episodes
# at 0.4 rad in the paper's and the lite configs). Epochs count from 0.
#
#   scripts/snapshot_eval.sh runs/lite/block_dense_fmsr_is_s0 target/release/fmsr 4 9 14 19 &
#
# Run it beside `fmsr train` (it polls metrics.csv every 15 s; an epoch of the
# lite configs takes minutes, so the copy is taken long before the next
# checkpoint replaces it). An epoch that was already passed when the script
# looked is reported as missed, never evaluated from a later checkpoint.
set -euo pipefail
if [ $# -lt 3 ]; then
  echo "usage: $0 RUN_DIR FMSR_BINARY EPOCH..." >&2
  exit 2
fi
run=$1
bin=$2
shift 2
epochs_done() { echo $(($(wc -l < "$1/metrics.csv") - 1)); }
# The epochs the run trains to ([trainer] epochs of its config.toml; a resume
# with --epochs rewrites it).
epochs_planned() { sed -n 's/^epochs = \([0-9]*\)$/\1/p' "$1/config.toml" | head -n 1; }
for k in "$@"; do
  snap="$run.snapshots/epoch-$(printf %02d "$k")"
  until [ -f "$run/config.toml" ]; do sleep 15; done
  if [ "$k" -ge "$(epochs_planned "$run")" ]; then
    echo "epoch $k: skipped (the run trains $(epochs_planned "$run") epochs, 0 to $(($(epochs_planned "$run") - 1)))"
    continue
  fi
  until [ -f "$run/metrics.csv" ] && [ "$(epochs_done "$run")" -ge $((k + 1)) ]; do
    sleep 15
  done
  if [ "$(epochs_done "$run")" -ne $((k + 1)) ]; then
    echo "epoch $k: missed (the run was at epoch $(($(epochs_done "$run") - 1)))"
    continue
  fi
  mkdir -p "$snap"
  cp "$run/config.toml" "$run/checkpoint.bin" "$run/metrics.jsonl" "$run/metrics.csv" "$snap/"
  nice -n 5 "$bin" eval "$snap" > "$snap/eval.log" 2>&1
  # `fmsr eval` names the epochs of the checkpoint it read: a copy that raced
  # the next epoch's checkpoint is caught here.
  if ! head -n 1 "$snap/eval.log" | grep -q ", $((k + 1)) epochs,"; then
    echo "epoch $k: missed (the copied checkpoint is not epoch $k's: $(head -n 1 "$snap/eval.log"))"
    mv "$snap" "$snap.raced"
    continue
  fi
  echo "epoch $k: $(grep -o 'test success.*rad)' "$snap/eval.log" | head -n 1)"
done
