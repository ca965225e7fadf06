#!/usr/bin/env bash
# One arm of a lite experiment (issue 52's E2/E3/E5, issue 53's item 3) that
# survives a session's end and a lost machine: trains RUN to 40 epochs (the
# lite configs' budget; --epochs to change it), optionally writing a rescue point after epoch
# --rescue-at on the way, then evaluates it as E2 did (the fixed test set on
# the run's engine, the validation episodes, the test set on the other engine) and
# exports its policy. Run it again at any later session: it goes on from
# where the run stands.
#
#   scripts/lite_arm.sh --bin FMSR --config C --seed S --engine E --run R [--rescue-at K] [--rescue-from F] [--epochs N]
#   scripts/lite_arm.sh --bin FMSR --run R --save DIR [--keep online|half] [--records DIR2]
#
# --save, at a session's end, trains nothing: it writes R's rescue point of
# now (`fmsr rescue --keep online`, or `half` where the tree lacks room: a
# build of 5cf0cd5 or later writes and reads it, whatever binary trains R) and
# its config.toml into DIR (to commit; a later session goes on from them with
# --rescue-from DIR/rescue.fmsr if R is lost), and with --records copies R's
# config.toml, provenance.json, metrics.csv and restarts.jsonl into DIR2.
#
# Where it goes on from, in order:
#   - R has a checkpoint: `fmsr train --resume` (exact, replay buffer included);
#   - else --rescue-from F (a rescue point committed to the repository, with
#     R's config.toml beside it): `fmsr train --rescue F --out R`, a restart
#     that the run's restarts.jsonl records (the replay buffer is lost);
#   - else a fresh start from --config with --seed and --engine.
# --rescue-at K stops after K epochs, writes R/rescue-epoch-0K.fmsr
# (`fmsr rescue --keep online`) and goes on: issue 53's item 3 restarts a copy
# of the run from it against the run itself.
#
# FMSR is a release build (with `--features mujoco` for MuJoCo runs:
# LD_LIBRARY_PATH must hold libmujoco, scripts/setup_mujoco.sh). Runs with one
# learner thread (RAYON_NUM_THREADS=1), so two arms side by side take a core each.
set -euo pipefail

bin= config= seed= engine= run= rescue_at= rescue_from= epochs=40 save= keep=online records=
while [ $# -gt 0 ]; do
  case $1 in
    --bin) bin=$2 ;;
    --config) config=$2 ;;
    --seed) seed=$2 ;;
    --engine) engine=$2 ;;
    --run) run=$2 ;;
    --rescue-at) rescue_at=$2 ;;
    --rescue-from) rescue_from=$2 ;;
    --epochs) epochs=$2 ;;
    --save) save=$2 ;;
    --keep) keep=$2 ;;
    --records) records=$2 ;;
    *) echo "$0: unknown argument $1" >&2; exit 2 ;;
  esac
  shift 2
done
for v in bin run; do
  [ -n "${!v}" ] || { echo "$0: --$v is required" >&2; exit 2; }
done
export RAYON_NUM_THREADS=1

train_to() {
  local to=$1
  if [ -f "$run/checkpoint.bin" ]; then
    "$bin" train --out "$run" --resume --epochs "$to" --quiet
  elif [ -n "$rescue_from" ]; then
    [ -f "$run/config.toml" ] || { echo "$0: $run/config.toml is needed beside --rescue-from" >&2; exit 2; }
    "$bin" train --rescue "$rescue_from" --out "$run" --epochs "$to" --quiet
  else
    for v in config seed engine; do
      [ -n "${!v}" ] || { echo "$0: --$v is required for a fresh start" >&2; exit 2; }
    done
    "$bin" train --config "$config" --engine "$engine" --seed "$seed" --out "$run" --epochs "$to" --quiet
  fi
}

done_epochs() {
  [ -f "$run/metrics.csv" ] && echo $(($(wc -l < "$run/metrics.csv") - 1)) || echo 0
}

if [ -n "$save" ]; then
  [ -f "$run/checkpoint.bin" ] || { echo "$0: $run has no checkpoint to save" >&2; exit 2; }
  mkdir -p "$save"
  "$bin" rescue "$run" --keep "$keep" --out "$save/rescue.fmsr.tmp"
  mv "$save/rescue.fmsr.tmp" "$save/rescue.fmsr"
  cp "$run/config.toml" "$save/config.toml"
  if [ -n "$records" ]; then
    mkdir -p "$records"
    for f in config.toml provenance.json metrics.csv restarts.jsonl; do
      if [ -f "$run/$f" ]; then cp "$run/$f" "$records/$f"; fi
    done
  fi
  echo "$run: saved after $(done_epochs) epochs into $save ($keep)${records:+, records into $records}"
  exit 0
fi

mkdir -p "$run"
if [ -n "$rescue_at" ]; then
  point=$(printf '%s/rescue-epoch-%03d.fmsr' "$run" "$rescue_at")
  if [ ! -f "$point" ] && [ "$(done_epochs)" -le "$rescue_at" ]; then
    train_to "$rescue_at"
    "$bin" rescue "$run" --keep online --out "$point.tmp"
    mv "$point.tmp" "$point"
  elif [ ! -f "$point" ]; then
    echo "$0: $run is past epoch $rescue_at without $point: no rescue point there (never one from a later epoch)" >&2
  fi
fi
train_to "$epochs"
# The run's own engine, then the other one on the test set (eval-<engine>.json).
trained_on=$(sed -n 's/^engine = "\(.*\)"$/\1/p' "$run/config.toml")
case $trained_on in
  mujoco) other=rapier ;;
  rapier) other=mujoco ;;
  *) echo "$0: no engine in $run/config.toml" >&2; exit 2 ;;
esac
[ -f "$run/eval.json" ] || "$bin" eval "$run"
[ -f "$run/eval-validation.json" ] || "$bin" eval "$run" --set validation
[ -f "$run/eval-$other.json" ] || "$bin" eval "$run" --engine "$other"
[ -f "$run/policy.fmsr" ] || "$bin" export "$run" --out "$run/policy.fmsr"
echo "$run: $epochs epochs, evaluated and exported"
