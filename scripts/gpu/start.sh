#!/usr/bin/env bash
# Step 2 of 4, on the GPU machine: starts `fmsr train` detached (its own
# session, so it outlives this command while the machine is held) on all
# cores and the GPU, and returns at once. A run directory that already holds a
# checkpoint is resumed. Start several to train them side by side.
#
#   scripts/gpu/start.sh configs/block_dense_fmsr_is.toml            # runs/gpu/block_dense_fmsr_is
#   scripts/gpu/start.sh configs/block_dense.toml NAME -- --seed 1   # extra `fmsr train` flags after --
#   FMSR_GPU_DEVICE=cpu scripts/gpu/start.sh ...                      # another device (default vulkan:0)
set -euo pipefail
cd "$(dirname "$0")/../.."
if [ $# -lt 1 ]; then
  echo "usage: $0 CONFIG [NAME] [-- TRAIN_FLAGS...]" >&2
  exit 2
fi
config=$1
shift
name=$(basename "$config" .toml)
if [ $# -gt 0 ] && [ "$1" != "--" ]; then
  name=$1
  shift
fi
[ "${1:-}" = "--" ] && shift
# shellcheck source=scripts/gpu/env.sh
. scripts/gpu/env.sh
run=runs/gpu/$name
mkdir -p runs/gpu
args=(train --config "$config" --device "${FMSR_GPU_DEVICE:-vulkan:0}" --out "$run" "$@")
if [ -f "$run/checkpoint.bin" ]; then
  args+=(--resume)
fi
setsid nohup "$FMSR" "${args[@]}" > "$run.log" 2>&1 < /dev/null &
pid=$!
echo "$pid" > "$run.pid"
sleep 5
if ! kill -0 "$pid" 2>/dev/null; then
  rc=0
  wait "$pid" || rc=$?
  if [ "$rc" -ne 0 ]; then
    echo "$name stopped at once (exit status $rc):" >&2
    cat "$run.log" >&2
    exit 1
  fi
  echo "$name already finished: $FMSR ${args[*]}"
  exit 0
fi
echo "started $name (pid $pid): $FMSR ${args[*]}"
