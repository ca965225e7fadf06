#!/usr/bin/env bash
# What a late restart from a rescue point costs, against the same run
# uninterrupted (docs/notebook/results.md, "Not run"; issue 53): twins from one
# checkpoint, trained to the same epoch, compared by scripts/restart_twins.py.
#
#   scripts/restart_twins.sh RUN OUT EPOCHS ARM...
#
# RUN     a run directory with a checkpoint, not training: its writer lock is
#         taken while it is copied (a long run's: once it has ended, e.g.
#         ~/.local/share/fmsr/long-runs/egg_dense_fmsr_is/run after `finish`).
# OUT     the twins' directory. The first call copies RUN into
#         OUT/uninterrupted, writes a rescue point of every KEEP from it into
#         OUT/split/ (with the run's config.toml, provenance.json and
#         restarts.jsonl), then OUT/twins.env (EPOCH0, the checkpoint's
#         epochs, RUN, the binary); OUT/<arm>/ is each arm's run.
# EPOCHS  the epoch every arm trains to (EPOCH0 + 10 gives the restart table's window).
# ARM     `uninterrupted` (the copy of RUN's checkpoint and replay log, resumed),
#         or KEEP or KEEP:REFILL: restarted from `fmsr rescue RUN --keep KEEP`
#         (online, half, targets, full) with `fmsr train --rescue --refill REFILL`
#         (exploring episodes into the empty buffer; default one epoch's).
#         `uninterrupted` must be among them: it is the reference. Each arm's
#         directory is OUT/<arm>, KEEP:REFILL as KEEP-refillREFILL.
#
# The arms train $FMSR_TWINS_JOBS at a time (default 1), each niced on one
# core (RAYON_NUM_THREADS=1, as the long runs); then each arm's last policy is
# evaluated on the test set (`fmsr eval`, the config's episodes, the engine
# it trained on), and the table goes to OUT/twins.md. A second call with the
# same OUT goes on: an arm at EPOCHS is left alone, one cut off resumes from
# its own checkpoint (a restart arm whose first epoch never ended restarts
# from its rescue point again), an arm added by a later call restarts from the
# split's rescue point as the first call's did, an evaluation of the arm's
# last checkpoint is kept.
# Binary: $FMSR_BIN, else target/release/fmsr (build with `--features mujoco`
# for a MuJoCo run; target/mujoco/lib is put on LD_LIBRARY_PATH).
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
die() { echo "restart_twins: $*" >&2; exit 1; }
[ $# -ge 4 ] || die "usage: $0 RUN OUT EPOCHS ARM... (see the header)"
run=$1 out=$2 epochs=$3
shift 3
arms=("$@")
fmsr=${FMSR_BIN:-$repo/target/release/fmsr}
[ -x "$fmsr" ] || die "no binary at $fmsr (set FMSR_BIN or build it)"
export LD_LIBRARY_PATH=$repo/target/mujoco/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
export RAYON_NUM_THREADS=1
[[ $epochs =~ ^[0-9]+$ ]] || die "EPOCHS must be a number of epochs: $epochs"
printf '%s\n' "${arms[@]}" | grep -qx uninterrupted || die "no \`uninterrupted\` arm: it is the reference"
for arm in "${arms[@]}"; do
  [ "$arm" = uninterrupted ] || [[ $arm =~ ^(online|half|targets|full)(:[0-9]+)?$ ]] \
    || die "arm \`$arm\`: not uninterrupted, KEEP or KEEP:REFILL (KEEP one of online, half, targets, full)"
done
[ "$(printf '%s\n' "${arms[@]}" | sort | uniq -d)" = "" ] || die "an arm is named twice: ${arms[*]}"

# Epochs an arm's run directory has trained (its metrics.csv's rows).
trained() { if [ -f "$1/metrics.csv" ]; then echo $(($(wc -l < "$1/metrics.csv") - 1)); else echo 0; fi; }

mkdir -p "$out"
if [ ! -f "$out/twins.env" ]; then
  [ -f "$run/checkpoint.bin" ] || die "$run has no checkpoint"
  # The source under its writer lock: no epoch ends while it is copied.
  [ -f "$run/.lock" ] || die "$run has no .lock: not a run directory \`fmsr train\` wrote"
  exec 9< "$run/.lock"
  flock -n 9 || die "$run is training ($(cat "$run/.lock")): twins start from a run that has stopped"
  e0=$(trained "$run")
  [ "$epochs" -gt "$e0" ] || die "EPOCHS ($epochs) must be past the checkpoint's $e0 epochs"
  # Nothing trained before twins.env: a call cut off here starts the split again.
  rm -rf "$out/uninterrupted" "$out/uninterrupted.tmp" "$out/split" "$out/split.tmp"
  mkdir -p "$out/uninterrupted.tmp" "$out/split.tmp"
  cp -a "$run/checkpoint.bin" "$run/checkpoint.replay" "$run/config.toml" "$run/metrics.csv" "$run/metrics.jsonl" \
    "$out/uninterrupted.tmp/"
  for f in provenance.json restarts.jsonl; do
    [ ! -f "$run/$f" ] || { cp -a "$run/$f" "$out/uninterrupted.tmp/" && cp -a "$run/$f" "$out/split.tmp/"; }
  done
  exec 9<&-
  cp "$run/config.toml" "$out/split.tmp/"
  # Every KEEP's rescue point at the split, before the copy trains on.
  for keep in online half targets full; do
    nice -n 10 "$fmsr" rescue "$out/uninterrupted.tmp" --keep "$keep" --out "$out/split.tmp/rescue-$keep.fmsr" > /dev/null
  done
  mv "$out/split.tmp" "$out/split"
  mv "$out/uninterrupted.tmp" "$out/uninterrupted"
  {
    echo "EPOCH0=$e0"
    echo "RUN=$(cd "$run" && pwd)"
    echo "BIN=$fmsr"
    echo "BUILD=\"$("$fmsr" --version)\""
    echo "STARTED=$(date -u +%FT%TZ)"
  } > "$out/twins.env.tmp"
  mv "$out/twins.env.tmp" "$out/twins.env"
fi
e0=$(sed -n 's/^EPOCH0=//p' "$out/twins.env")
[ "$epochs" -gt "$e0" ] || die "EPOCHS ($epochs) must be past the twins' start, $e0 epochs"

# An arm's run directory's name: KEEP:REFILL is KEEP-refillREFILL.
arm_dir() { echo "$out/${1/:/-refill}"; }

# One arm, to EPOCHS; its log is beside its directory (.log).
train_arm() {
  local arm=$1 dir keep refill
  dir=$(arm_dir "$arm")
  if [ "$(trained "$dir")" -ge "$epochs" ]; then return 0; fi
  if [ "$arm" = uninterrupted ] || { [ -f "$dir/checkpoint.bin" ] && [ "$(trained "$dir")" -gt "$e0" ]; }; then
    nice -n 10 "$fmsr" train --out "$dir" --resume --epochs "$epochs" --quiet
  else
    keep=${arm%%:*} refill=
    [ "$keep" = "$arm" ] || refill=${arm#*:}
    rm -rf "$dir"
    mkdir -p "$dir"
    for f in config.toml provenance.json restarts.jsonl; do [ ! -f "$out/split/$f" ] || cp "$out/split/$f" "$dir/"; done
    nice -n 10 "$fmsr" train --out "$dir" --rescue "$out/split/rescue-$keep.fmsr" ${refill:+--refill "$refill"} \
      --epochs "$epochs" --quiet
  fi
}

jobs_max=${FMSR_TWINS_JOBS:-1}
[[ $jobs_max =~ ^[1-9][0-9]*$ ]] || die "FMSR_TWINS_JOBS must be a positive number: $jobs_max"
pids=()
for arm in "${arms[@]}"; do
  while [ "$(jobs -rp | wc -l)" -ge "$jobs_max" ]; do sleep 5; done
  (train_arm "$arm" > "$(arm_dir "$arm").log" 2>&1 || { echo "FAILED" >> "$(arm_dir "$arm").log"; exit 1; }) &
  pids+=($!)
done
failed=0
for i in "${!pids[@]}"; do
  wait "${pids[$i]}" || { echo "restart_twins: arm ${arms[$i]} failed: $(tail -n 3 "$(arm_dir "${arms[$i]}").log")" >&2; failed=1; }
done
[ "$failed" = 0 ] || exit 1

for arm in "${arms[@]}"; do
  dir=$(arm_dir "$arm")
  [ "$(trained "$dir")" -eq "$epochs" ] || die "arm $arm trained $(trained "$dir") epochs, not $epochs"
  [ -f "$dir/eval.json" ] && [ ! "$dir/checkpoint.bin" -nt "$dir/eval.json" ] \
    || nice -n 10 "$fmsr" eval "$dir" > "$dir.eval.log" 2>&1 \
    || die "arm $arm: fmsr eval failed: $(tail -n 3 "$dir.eval.log")"
done
python3 "$repo/scripts/restart_twins.py" "$out" > "$out/twins.md.tmp"
mv "$out/twins.md.tmp" "$out/twins.md"
cat "$out/twins.md"
