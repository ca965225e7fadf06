#!/usr/bin/env bash
# The keeper of long training runs: runs that take days of wall time, carried
# across sessions that each end every process, in a home outside the work tree.
#
#   scripts/long_runs.sh start CONFIG...   copy the release binary, start each run
#   FMSR_LONG_RUNS_BIN=BIN scripts/long_runs.sh start CONFIG...   start with an earlier run's binary in the home's bin/ (one build for both arms of a pair)
#   scripts/long_runs.sh resume            restart every unfinished run, from its rescue point where the home lost it (first thing every session)
#   scripts/long_runs.sh status            epochs, env steps, success, s/epoch, sessions left, alive, next snapshot
#   scripts/long_runs.sh record            evaluate new snapshots, copy small files into docs/
#   scripts/long_runs.sh finish            once every run has ended: issue 37's item 4 (below); ~30 min for the pair, run it with nohup
#   scripts/long_runs.sh finish RUN...     the final evaluations and policies of runs that ended, ahead of the others (no report)
#   scripts/long_runs.sh lost              the home is gone: mark the recorded runs lost, rewrite the section
#
# The home is `$FMSR_LONG_RUNS`, else `$HOME/.local/share/fmsr/long-runs`:
#
#   bin/fmsr-<commit>             the binary a run was started with (never changed mid-run)
#   <run>/keeper.env              BIN, EPOCHS, COMMIT and where the run was started
#   <run>/config.toml             the experiment as given, with one stepping and one learner thread
#   <run>/run/                    the `fmsr train` run directory (checkpoint, replay, logs)
#   <run>/snapshots/epoch-K.fmsr  the policy after epoch K (counted from 0), `fmsr export`
#   <run>/keeper.log              the driver's and training's output
#   <run>/keeper.sh               the copy of this script the driver runs
#   <run>/keeper.lock             held (flock) by the one driver of the run while it lives
#
# Each run is one driver process, started with nohup and nice -n 19, that
# trains up to the next snapshot epoch (`fmsr train --resume --epochs K+1`),
# exports the snapshot, and goes on to the next; so a run resumed any number of
# times trains exactly as an uninterrupted one, and its snapshots are taken
# from the checkpoint of their own epoch. The driver holds the run's lock for
# its whole life (its `fmsr train` children inherit it): a second driver on
# the same run exits at once; `fmsr train` from builds after 2026-11-25 also
# refuses a run directory another process writes.
#
# `record` evaluates, with the work tree's current release build (with MuJoCo,
# as `finish`'s, since a run trained there is evaluated there), each snapshot not yet
# evaluated on the fixed test set (the config's [eval]: 100 episodes at 0.4 rad
# in the paper's configs) and on the validation episodes (seeds disjoint from
# the test set's, used to choose a snapshot), copies config, provenance,
# metrics.csv and those evaluations (trimmed of per-step traces) into the
# campaign's records, RECORDS/<run>/ (below), and regenerates the campaign's
# section in RESULTS (scripts/long_runs_record.py). Checkpoints, replay and
# policies stay in the home until a run ends.
#
# Campaigns. Run names come from the configs' `name`, so two campaigns of the
# same pair have runs of the same names; each keeps its files apart by its
# records, its suffix in pretrained/ and its section:
#
#   RECORDS      FMSR_LONG_RUNS_RECORDS, default docs/results/paper_stack: a
#                directory per run, curves.svg, report/; RECORDS_lost/ the
#                records of earlier runs of the same names lost with their home
#   SUFFIX       FMSR_LONG_RUNS_SUFFIX, default `_paper_stack`: each run's
#                policies and rescue point in pretrained/<run>SUFFIX/
#                (FMSR_LONG_RUNS_PRETRAINED, default pretrained/)
#   RESULTS      FMSR_LONG_RUNS_RESULTS, default RECORDS/README.md (created,
#                with a line above the section, when missing): the section,
#                between the markers `<!-- M:begin ...-->` and `<!-- M:end -->`,
#                M the records directory's name with `-` for `_` (paper-stack)
#   HEADING      FMSR_LONG_RUNS_HEADING, the section's heading, default "The
#                paper's stack at the paper's budget: the egg, Dense+FMSR+IS
#                against Dense, 400 epochs"
#
# The defaults are the current campaign's: the pair of configs/mujoco/egg_dense.toml
# and egg_dense_fmsr_is.toml under `stack = "paper"`, 400 epochs. The first
# campaign, the same pair at the paper's budget before that preset, has ended;
# its records are docs/results/paper_budget/, its policies pretrained/<run>_paper/,
# its section "The paper's budget" in docs/notebook/results.md (where its summary line,
# between M-summary markers, and pretrained/README.md's index of its policies,
# between M-policies markers, are written too). It is addressed, to rewrite its
# section for instance, as
#
#   FMSR_LONG_RUNS_SUFFIX=_paper FMSR_LONG_RUNS_RECORDS=docs/results/paper_budget \
#     FMSR_LONG_RUNS_RESULTS=docs/notebook/results.md \
#     FMSR_LONG_RUNS_HEADING="The paper's budget: the egg, Dense+FMSR+IS against Dense, 400 epochs" \
#     scripts/long_runs.sh ...
#
# The home is one for every campaign: `start` refuses a run name the home holds,
# so the ended runs of a campaign leave it (moved aside, or FMSR_LONG_RUNS names
# another home) before the next campaign starts the same names; `record` and
# `finish` take every run in the home as the campaign's.
#
# `finish` refuses until every run has trained its epochs and taken its
# snapshots. Then, with one release build `--features mujoco` for every
# evaluation, per run: the policy after the last epoch (`final.fmsr` in the
# home, exported by the run's own binary: no selection), evaluated on the fixed
# test set, on the validation episodes and on the first TRIALS test episodes
# (the paper's Table II: 500), on rapier and on MuJoCo, each engine named
# (`--engine`: `fmsr eval` alone takes the engine the run trained on), into
# RECORDS/<run>/final/; that policy at half precision, carrying its own
# evaluations (`fmsr eval --record`, also in final/ as *-half.json), as
# pretrained/<run>SUFFIX/policy.fmsr, with the
# snapshot best on the validation episodes beside it (best_on_validation.fmsr,
# unless it is the final one), test episode 0 rendered on the engine the run
# trained on and a README; the rescue point and best_so_far.fmsr, which an
# ended run no longer needs, are removed from pretrained/<run>SUFFIX/ (git's
# history keeps them; the tree would not hold them beside the final policies); then
# `fmsr report` over those policies into RECORDS/report/, and
# the section again, now with the comparison with the paper
# (scripts/long_runs_final.py). Each step skips what an earlier `finish` wrote,
# so a cut-off `finish` is run again. Overrides (for a trial on a scratch
# home): FMSR_LONG_RUNS_RECORDS, FMSR_LONG_RUNS_PRETRAINED,
# FMSR_LONG_RUNS_RESULTS, FMSR_LONG_RUNS_SUFFIX, FMSR_LONG_RUNS_HEADING,
# FMSR_LONG_RUNS_TRIALS.
#
# Rescue points (issue 53). `record` also writes the rescue point of each run
# still training, `fmsr rescue RUN --keep $FMSR_LONG_RUNS_KEEP` (default
# `half`: the online networks at half precision, normalisers, RNG, counters
# and occupancy, no replay, about 3.9 MB for the paper's networks; `online`
# keeps the networks at full precision, about 7.3 MB), into
# pretrained/<run>SUFFIX/rescue/ (rescue.fmsr, rescue.env: EPOCH, KEEP,
# WRITTEN, STARTED; restarts.jsonl stays in the records), and copies the
# snapshot best on the validation episodes so far to
# pretrained/<run>SUFFIX/best_so_far.fmsr (best_so_far.env: EPOCH), so a
# policy and the state to go on from are in the repository whatever happens
# to the home. Every version written there stays in git's history, so not at
# every `record`: a run's rescue point is (re)written only while the run has
# epochs left to train, and only when pretrained/ has none of this run yet or
# the one there is about a day of training old, the `seconds` of the
# metrics.csv epochs after its EPOCH adding up to FMSR_LONG_RUNS_RESCUE_EVERY
# (default 86400) or more, or about a day old by the clock, its WRITTEN
# FMSR_LONG_RUNS_RESCUE_AGE seconds ago or more (default 72000) with
# FMSR_LONG_RUNS_RESCUE_FLOOR seconds of training after it (default 3600):
# the home has been lost about once a day, after less than a day of training
# (scripts/long_runs_rescue.py, its header). Otherwise `record`
# leaves it and says so in a line. best_so_far.fmsr follows it: copied when
# the rescue point is rewritten, or when there is none yet. A home lost
# costs the training since its runs' rescue points: at most about a day and a
# session's, also for a run that has trained all its epochs and waits for
# `finish`. `resume` restores every recorded run that the home lacks and
# that has a rescue point: a new home entry with the run's config and
# keeper.env, this work tree's release build as its binary (BIN_NOTE says so:
# the rescue point's format is checked by its reader), and the rescue point,
# from which the driver restarts (`fmsr train --rescue`) before it goes on as
# ever; the restart goes into the run's restarts.jsonl, the section and the
# curves. What the records hold of epochs past the rescue point (their
# snapshots' evaluations, the metrics of the loss) was trained on the lost
# home: `resume` moves it to RECORDS/<run>/lost-<when>/, and the restored
# run's own snapshots of those epochs are taken and evaluated. Snapshots lost
# with a home count as taken when the records hold their evaluations.
#
# `lost` is for a session that finds the home gone (a machine not kept from
# the session before: every checkpoint, replay buffer, snapshot policy and the
# binary with it). It refuses for any run the home still holds; for the others
# it writes RECORDS/<run>/lost.env (FOUND: when the loss was
# found) and rewrites the section from the records alone, saying the runs were
# lost and at which epoch their record stops. A later `start` of the same runs
# moves those records to RECORDS_lost/ as for any earlier run; a `record`
# that finds the run in the home after all removes the mark.
set -euo pipefail

repo=$(cd "$(dirname "$0")/.." && pwd)
home=${FMSR_LONG_RUNS:-$HOME/.local/share/fmsr/long-runs}
# The campaign (see the header): its records, its runs' suffix in pretrained/,
# its results file and its section's heading.
records=${FMSR_LONG_RUNS_RECORDS:-$repo/docs/results/paper_stack}
pretrained=${FMSR_LONG_RUNS_PRETRAINED:-$repo/pretrained}
suffix=${FMSR_LONG_RUNS_SUFFIX:-_paper_stack}
results=${FMSR_LONG_RUNS_RESULTS:-$records/README.md}
heading=${FMSR_LONG_RUNS_HEADING:-"The paper's stack at the paper's budget: the egg, Dense+FMSR+IS against Dense, 400 epochs"}
# Paths given relative are from where the keeper was called (its commands cd to the repository).
absolute() { case $1 in /*) echo "$1" ;; *) echo "$PWD/$1" ;; esac; }
records=$(absolute "$records") pretrained=$(absolute "$pretrained") results=$(absolute "$results")
trials=${FMSR_LONG_RUNS_TRIALS:-500}
# What a rescue point keeps (`fmsr rescue --keep`): online, half, targets or full.
keep=${FMSR_LONG_RUNS_KEEP:-half}
# Seconds of training after which `record` rewrites a run's rescue point.
rescue_every=${FMSR_LONG_RUNS_RESCUE_EVERY:-86400}
# ... or after this many seconds by the clock, when the run trained FLOOR seconds since it.
rescue_age=${FMSR_LONG_RUNS_RESCUE_AGE:-72000}
rescue_floor=${FMSR_LONG_RUNS_RESCUE_FLOOR:-3600}
# Epochs (from 0) after which the policy is exported.
snapshot_epochs=(0 9 24 49 99 149 199 249 299 349 399)
# Seconds of training one session gives a run (a session lasts 180 minutes).
session_seconds=$((170 * 60))

die() { echo "long_runs: $*" >&2; exit 1; }
log() { echo "[$(date -u +%FT%TZ)] $*"; }

# Epochs trained: the data rows of metrics.csv.
epochs_done() {
  local csv=$1/run/metrics.csv
  if [ -f "$csv" ] && [ -f "$1/run/checkpoint.bin" ]; then echo $(($(wc -l < "$csv") - 1)); else echo 0; fi
}

# Whether the run's driver is alive: its lock is held.
alive() { ! flock -n "$1/keeper.lock" true 2>/dev/null; }

# The run's planned epochs (keeper.env).
planned() { (source "$1/keeper.env"; echo "$EPOCHS"); }

finished() {
  local dir=$1 k name
  name=$(basename "$dir")
  [ "$(epochs_done "$dir")" -ge "$(planned "$dir")" ] || return 1
  for k in "${snapshot_epochs[@]}"; do
    [ "$k" -ge "$(planned "$dir")" ] || [ -f "$dir/snapshots/epoch-$(printf %03d "$k").fmsr" ] \
      || [ -f "$records/$name/snapshots/epoch-$(printf %03d "$k").test.json" ] || return 1
  done
}

# The driver of one run (runs in the background, holding the run's lock).
drive() {
  local dir=$1
  exec 9> "$dir/keeper.lock"
  # Wait a little: `alive` probes the lock by taking it for an instant (the
  # launcher does so right after starting this driver), and a driver that gave
  # up at once on meeting a probe would leave its run stopped (2026-11-26).
  # A driver holds the lock for its whole life, so after 5 s it is one.
  flock -w 5 9 || { log "another driver holds $dir"; exit 0; }
  # nice alone does not yield to the session's work: the driver has its own
  # session (setsid), hence its own scheduler autogroup, which the kernel
  # weighs equally with the foreground's whatever the processes' nice. Nice
  # the autogroup too, so builds and tests come first.
  echo 19 > /proc/self/autogroup 2> /dev/null || true
  # shellcheck disable=SC1091
  source "$dir/keeper.env"
  export RAYON_NUM_THREADS=1
  # glibc keeps freed memory for the next step, as fmsr::allocator sets it in
  # binaries since ccfaceb (the batch-1024 update 20-27 % faster on one thread,
  # results bit for bit the same); a binary built before it takes it from here.
  export GLIBC_TUNABLES=glibc.malloc.mmap_threshold=33554432:glibc.malloc.trim_threshold=1073741824
  # A MuJoCo run's binary finds libmujoco in the home (copied by start or resume).
  export LD_LIBRARY_PATH=$home/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
  log "driver $$ on $(basename "$dir") with $BIN"
  local k target trained snap
  for k in "${snapshot_epochs[@]}"; do
    target=$((k + 1))
    [ "$target" -le "$EPOCHS" ] || break
    trained=$(epochs_done "$dir")
    if [ "$trained" -lt "$target" ]; then
      if [ ! -f "$dir/run/checkpoint.bin" ] && [ -f "$dir/rescue.fmsr" ]; then
        # A run restored from its rescue point (`resume` after a lost home):
        # restart from it, then the rescue point has served.
        "$BIN" train --rescue "$dir/rescue.fmsr" --out "$dir/run" --epochs "$target" \
          && mv "$dir/rescue.fmsr" "$dir/rescue.used.fmsr"
      elif [ ! -f "$dir/run/checkpoint.bin" ]; then
        # Nothing to resume (a first epoch that never ended): start afresh, in
        # the checkout it was started from so provenance.json names the commit.
        rm -rf "$dir/run"
        (cd "$START_DIR" 2> /dev/null || cd "$dir"
         "$BIN" train --config "$dir/config.toml" --out "$dir/run" --epochs "$target")
      else
        "$BIN" train --out "$dir/run" --resume --epochs "$target"
      fi
      trained=$(epochs_done "$dir")
    fi
    snap=$dir/snapshots/epoch-$(printf %03d "$k").fmsr
    if [ ! -f "$snap" ]; then
      if [ "$trained" -ne "$target" ]; then
        # A run restored from its rescue point is past the snapshots it took
        # before the home was lost: their evaluations are in the records.
        if [ -f "$dir/rescue.used.fmsr" ]; then
          log "snapshot of epoch $k not in this home: the run, restored from its rescue point, is at $trained epochs (snapshots recorded before the loss are in the records)"
        else
          log "snapshot of epoch $k missed: the run is at $trained epochs"
        fi
        continue
      fi
      mkdir -p "$dir/snapshots"
      # The export names the epochs of the checkpoint it read: it must be this one's.
      "$BIN" export "$dir/run" --out "$snap.tmp" | tee "$snap.log"
      grep -q "after $target epochs" "$snap.log" || { log "snapshot of epoch $k: the checkpoint is not epoch $k's"; exit 1; }
      mv "$snap.tmp" "$snap"
      log "snapshot of epoch $k: $snap"
    fi
  done
  if [ "$(epochs_done "$dir")" -lt "$EPOCHS" ]; then
    "$BIN" train --out "$dir/run" --resume --epochs "$EPOCHS"
  fi
  log "finished: $(epochs_done "$dir") of $EPOCHS epochs"
}

launch() {
  local dir=$1
  if alive "$dir"; then
    echo "$(basename "$dir"): training (driver alive), left alone"
    return
  fi
  if finished "$dir"; then
    echo "$(basename "$dir"): finished ($(epochs_done "$dir") epochs)"
    return
  fi
  # The driver runs from its own copy of this script: bash reads a script as it
  # goes, so an edit of the work tree's copy must not reach a running driver.
  cp "$repo/scripts/long_runs.sh" "$dir/keeper.sh.tmp" && mv "$dir/keeper.sh.tmp" "$dir/keeper.sh"
  setsid nohup nice -n 19 bash "$dir/keeper.sh" _drive "$dir" >> "$dir/keeper.log" 2>&1 < /dev/null &
  # The driver takes its lock at once; wait for it so a second call sees it.
  for _ in $(seq 50); do alive "$dir" && break; sleep 0.1; done
  if [ -f "$dir/rescue.fmsr" ] && [ ! -f "$dir/run/checkpoint.bin" ]; then
    # Restored by `resume`: no checkpoint yet, the driver restarts from the rescue point.
    echo "$(basename "$dir"): started from its rescue point of epoch $(sed -n 's/^EPOCH=//p' "$dir/rescue.env" 2> /dev/null) (log $dir/keeper.log)"
  else
    echo "$(basename "$dir"): started at epoch $(epochs_done "$dir") (log $dir/keeper.log)"
  fi
}

# The config with one stepping thread and one learner thread: `threads` in
# [trainer] and [networks] (neither changes the results).
one_core_config() {
  awk '
    /^\[/ { section = $0 }
    section == "[trainer]" && /^threads *=/ { next }
    section == "[networks]" && /^threads *=/ { next }
    { print }
    $0 == "[trainer]" { print "threads = 1" }
    $0 == "[networks]" { print "threads = 1" }
    END { }
  ' "$1"
  grep -q '^\[networks\]' "$1" || printf '\n[networks]\nthreads = 1\n'
}

start() {
  [ $# -ge 1 ] || die "usage: $0 start CONFIG..."
  cd "$repo"
  git diff --quiet HEAD -- || die "tracked files differ from HEAD: commit first, so the binary is named by the code it was built from"
  local bin
  bin=$(home_binary "$@")
  local config name dir epochs
  for config in "$@"; do
    [ -f "$config" ] || die "no config $config"
    name=$(sed -n 's/^name *= *"\(.*\)"$/\1/p' "$config" | head -n 1)
    [ -n "$name" ] || die "$config names no run (name = \"...\")"
    epochs=$(awk '/^\[/ { s = $0 } s == "[trainer]" && /^epochs *=/ { print $3; exit }' "$config")
    [ -n "$epochs" ] || die "$config sets no [trainer] epochs"
    dir=$home/$name
    [ ! -e "$dir" ] || die "$dir exists: a run of that name was started before (resume it, or remove it)"
    mkdir -p "$dir"
    one_core_config "$config" > "$dir/config.toml"
    cat > "$dir/keeper.env" << EOF
BIN=$bin
EPOCHS=$epochs
COMMIT=$(bin_commit "$bin")
CONFIG=$config
START_DIR=$repo
STARTED=$(date -u +%FT%TZ)
EOF
    launch "$dir"
  done
}

# The commit a home binary was built from (its name holds the short hash).
bin_commit() {
  local short
  short=$(basename "$1" | sed -n 's/^fmsr-\([0-9a-f]*\).*/\1/p')
  git -C "$repo" rev-parse "$short^{commit}"
}

runs() { for d in "$home"/*/; do [ -f "$d/keeper.env" ] && echo "${d%/}"; done; }

# Builds this work tree's release binary (with MuJoCo when a config $@ asks for
# it, libmujoco then copied to $home/lib), copies it to $home/bin named by the
# commit, and prints its path.
home_binary() {
  cd "$repo"
  local features=() bin
  if [ -n "${FMSR_LONG_RUNS_BIN:-}" ]; then
    # The binary of a run started earlier, so that the arms of one comparison
    # run one build (`start` records its commit, not the work tree's).
    [ -x "$FMSR_LONG_RUNS_BIN" ] || die "FMSR_LONG_RUNS_BIN=$FMSR_LONG_RUNS_BIN is not an executable"
    case $FMSR_LONG_RUNS_BIN in "$home"/bin/fmsr-*) ;; *) die "FMSR_LONG_RUNS_BIN must be one of $home/bin/" ;; esac
    if grep -qs '^engine *= *"mujoco"' "$@"; then
      case $FMSR_LONG_RUNS_BIN in *-mujoco) ;; *) die "$FMSR_LONG_RUNS_BIN has no MuJoCo, which $* asks for" ;; esac
    fi
    echo "$FMSR_LONG_RUNS_BIN"
    return
  fi
  if grep -qs '^engine *= *"mujoco"' "$@"; then
    scripts/setup_mujoco.sh >&2
    features=(--features mujoco)
    mkdir -p "$home/lib"
    cp -a target/mujoco/lib/. "$home/lib/"
  fi
  cargo build --release "${features[@]}" --bin fmsr >&2
  bin=$home/bin/fmsr-$(git rev-parse --short=10 HEAD)${features:+-mujoco}
  mkdir -p "$home/bin"
  if [ ! -x "$bin" ]; then
    cp target/release/fmsr "$bin.tmp" && mv "$bin.tmp" "$bin"
  fi
  echo "$bin"
}

# Where the rescue point of the run recorded in $1 (its records' directory)
# lies: beside its policies in pretrained/<run>SUFFIX/ (tracked files over
# 2 MiB belong there), not in its records.
rescue_dir() { echo "$pretrained/$(basename "$1")$suffix/rescue"; }

# Whether `finish` ended recorded run $1 (its records' directory): its final
# policies are in pretrained/, and it neither needs nor gets a rescue point or a
# best policy so far. finished.env is written by finish_run's last step, so a
# `finish` cut off midway leaves the rescue point counted (and restorable).
finished_out() { [ -f "$1/final/finished.env" ]; }

# What the records of run $1 (its records' directory) hold of its epochs from
# $2 on (the rescue point's EPOCH, the epochs it has trained) was trained on
# a home now lost: the restored run trains those epochs again, otherwise.
# The evaluations of its snapshots of those epochs, and the metrics.csv of
# the loss, move to $1/lost-<when>/ (the section reads $1/snapshots alone),
# so that the restored run's own snapshots of those epochs are evaluated
# and no table mixes the two.
set_aside_lost() {
  local out=$1 epoch=$2 aside f k
  aside=$out/lost-$(date -u +%Y%m%dT%H%M%SZ)
  for f in "$out"/snapshots/epoch-*; do
    [ -f "$f" ] || continue
    k=$(basename "$f" | sed -n 's/^epoch-0*\([0-9][0-9]*\)\..*/\1/p')
    [ -n "$k" ] && [ "$k" -ge "$epoch" ] || continue
    mkdir -p "$aside/snapshots"
    mv "$f" "$aside/snapshots/"
  done
  if [ -f "$out/metrics.csv" ] && [ "$(($(wc -l < "$out/metrics.csv") - 1))" -gt "$epoch" ]; then
    mkdir -p "$aside"
    cp "$out/metrics.csv" "$aside/metrics.csv"
  fi
  if [ -d "$aside" ]; then
    echo "$(basename "$out"): the records of epochs $epoch on, trained on the lost home, set aside in $aside"
  fi
}

# Restores recorded run $1 (its records' directory) into the home from its
# rescue point, with this work tree's build; the driver restarts from it.
restore_from_rescue() {
  local out=$1 name dir bin
  name=$(basename "$out")
  dir=$home/$name
  mkdir -p "$dir/run"
  cp "$out/config.toml" "$dir/config.toml"
  cp "$out/config.toml" "$dir/run/config.toml"
  if [ -f "$out/provenance.json" ]; then cp "$out/provenance.json" "$dir/run/provenance.json"; fi
  if [ -f "$out/restarts.jsonl" ]; then cp "$out/restarts.jsonl" "$dir/run/restarts.jsonl"; fi
  cp "$(rescue_dir "$out")/rescue.fmsr" "$dir/rescue.fmsr"
  cp "$(rescue_dir "$out")/rescue.env" "$dir/rescue.env"
  set_aside_lost "$out" "$(sed -n 's/^EPOCH=//p' "$(rescue_dir "$out")/rescue.env")"
  bin=$(home_binary "$dir/config.toml")
  # Today's snapshots of the run are gone with the home; the best so far is in pretrained/.
  # keeper.env as recorded (COMMIT, STARTED: the run's), with today's binary.
  {
    grep -v -e '^BIN=' -e '^BIN_NOTE=' "$out/keeper.env"
    echo "BIN=$bin"
    echo "BIN_NOTE=\"restored $(date -u +%FT%TZ) from the rescue point of epoch $(sed -n 's/^EPOCH=//p' "$(rescue_dir "$out")/rescue.env") with the build of $(git -C "$repo" rev-parse --short=10 HEAD), not the run's own commit\""
  } > "$dir/keeper.env.tmp"
  mv "$dir/keeper.env.tmp" "$dir/keeper.env"
  echo "$name: restored from its rescue point ($(tr '\n' ' ' < "$(rescue_dir "$out")/rescue.env"))"
}

# The runs' records in docs/ (each holds its keeper.env), as `runs` lists the home's.
recorded() { for d in "$records"/*/; do if [ -f "$d/keeper.env" ]; then echo "${d%/}"; fi; done; }

# Runs recorded in docs/ but neither in the home nor marked lost.
unaccounted() {
  local out
  for out in $(recorded); do
    [ -f "$home/$(basename "$out")/keeper.env" ] || [ -f "$out/lost.env" ] || finished_out "$out" || basename "$out"
  done
}

resume() {
  local out restored=0
  for out in $(recorded); do
    [ ! -f "$home/$(basename "$out")/keeper.env" ] && [ -f "$(rescue_dir "$out")/rescue.fmsr" ] || continue
    finished_out "$out" && continue
    restore_from_rescue "$out"
    rm -f "$out/lost.env"
    restored=1
  done
  [ "$restored" = 0 ] || echo "(restored runs restart from their rescue points; \`$0 record\` commits where they stand)"
  if [ ! -d "$home" ]; then
    echo "no long-run home at $home (nothing to resume)"
    local missing
    missing=$(unaccounted | tr '\n' ' ')
    [ -z "$missing" ] || echo "recorded in $records but not in the home: ${missing% }; if the home was lost, \`$0 lost\` says so in the records"
    return
  fi
  local dir any=0
  for dir in $(runs); do any=1; launch "$dir"; done
  [ "$any" = 1 ] || echo "no runs in $home"
}

# The next snapshot after `$1` of `$2` epochs trained, and when it should be
# taken at `$3` seconds an epoch (while the driver runs).
next_snapshot() {
  local k
  for k in "${snapshot_epochs[@]}"; do
    if [ "$k" -ge "$1" ] && [ "$k" -lt "$2" ]; then
      echo "epoch $k, $(date -u -d "@$(awk -v n=$((k + 1 - $1)) -v s="$3" -v now="$(date +%s)" 'BEGIN { printf "%d", now + n * s }')" +%FT%H:%MZ)"
      return
    fi
  done
  echo "none left"
}

status() {
  [ -d "$home" ] || { echo "no long-run home at $home"; return; }
  printf '%-20s %9s %10s %6s %6s %8s %13s %-7s %s\n' run epochs env_steps train eval s/epoch sessions_left driver \
    "next snapshot (at the median pace)"
  local dir
  for dir in $(runs); do
    local csv=$dir/run/metrics.csv trained total
    trained=$(epochs_done "$dir")
    total=$(planned "$dir")
    if [ "$trained" -gt 0 ]; then
      # The columns by name: their places moved when metrics.csv gained some (2026-11-27).
      local last med
      col() { head -n 1 "$csv" | tr ',' '\n' | grep -nx "$1" | cut -d: -f1; }
      last=$(tail -n 1 "$csv")
      med=$(tail -n +2 "$csv" | tail -n 10 | cut -d, -f"$(col seconds)" | sort -g | awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }')
      printf '%-20s %4d/%-4d %10s %6.3f %6.3f %8.0f %13.1f %-7s %s\n' "$(basename "$dir")" "$trained" "$total" \
        "$(echo "$last" | cut -d, -f"$(col env_steps)")" "$(echo "$last" | cut -d, -f"$(col train_success_rate)")" \
        "$(echo "$last" | cut -d, -f"$(col success_rate)")" "$med" \
        "$(awk -v n=$((total - trained)) -v s="$med" -v t=$session_seconds 'BEGIN { print n * s / t }')" \
        "$(alive "$dir" && echo alive || echo stopped)" "$(next_snapshot "$trained" "$total" "$med")"
    else
      printf '%-20s %4d/%-4d %10s %6s %6s %8s %13s %-7s %s\n' "$(basename "$dir")" 0 "$total" - - - - - \
        "$(alive "$dir" && echo alive || echo stopped)" -
    fi
  done
}

# A record in docs/ of an earlier run of the same name (its home was lost and
# the run started again, so keeper.env differs) would pass its snapshots'
# evaluations off as the new run's: move it to RECORDS_lost/.
archive_earlier_record() {
  local dir=$1 out=$2 was
  # The same run keeps its STARTED (a run restored from its rescue point has
  # another binary, so keeper.env differs in BIN alone).
  started() { sed -n 's/^STARTED=//p' "$1"; }
  [ -f "$out/keeper.env" ] && [ "$(started "$out/keeper.env")" != "$(started "$dir/keeper.env")" ] || return 0
  was=$(sed -n 's/^STARTED=//p' "$out/keeper.env" | tr -d ':')
  mkdir -p "${records}_lost"
  mv "$out" "${records}_lost/$(basename "$out")-$was"
  echo "$(basename "$out"): the record of the run started $was is an earlier run's: moved to $(basename "$records")_lost/"
}

# Evaluates, with the work tree's release build, every snapshot not yet
# evaluated, and copies each run's small files into the records.
evaluate_snapshots() {
  local dir name out snap k f
  for dir in $(runs); do
    name=$(basename "$dir")
    out=$records/$name
    archive_earlier_record "$dir" "$out"
    mkdir -p "$out/snapshots"
    for f in config.toml provenance.json metrics.csv; do
      [ -f "$dir/run/$f" ] && cp "$dir/run/$f" "$out/$f"
    done
    cp "$dir/keeper.env" "$out/keeper.env"
    if [ -f "$dir/run/restarts.jsonl" ]; then cp "$dir/run/restarts.jsonl" "$out/restarts.jsonl"; fi
    # The home holds the run: whatever an earlier `lost` said, it is not lost.
    rm -f "$out/lost.env"
    for snap in "$dir"/snapshots/epoch-*.fmsr; do
      [ -f "$snap" ] || continue
      k=$(basename "$snap" .fmsr)
      if [ ! -f "$out/snapshots/$k.test.json" ]; then
        echo "$name $k: the test set"
        nice -n 5 "$fmsr" eval "$snap" --out "$out/snapshots/$k.test.json" > "$out/snapshots/$k.test.log" 2>&1
      fi
      if [ ! -f "$out/snapshots/$k.validation.json" ]; then
        echo "$name $k: the validation episodes"
        nice -n 5 "$fmsr" eval "$snap" --set validation --out "$out/snapshots/$k.validation.json" \
          > "$out/snapshots/$k.validation.log" 2>&1
      fi
    done
  done
}

# Each run's rescue point (from its last checkpoint) and its best policy on
# the validation episodes so far, into pretrained/, when due: while the run has
# epochs left to train, when pretrained/ has none of this run yet or a day of
# training, or a day by the clock with an hour of training, has passed since
# it (scripts/long_runs_rescue.py, the header).
rescue_and_best() {
  local dir name out epoch best pre snap rescue verdict fresh had args
  for dir in $(runs); do
    name=$(basename "$dir")
    out=$records/$name
    # After `finish` the policies in pretrained/ are the final ones (it removed these).
    finished_out "$out" && continue
    epoch=$(epochs_done "$dir")
    rescue=$(rescue_dir "$out")
    pre=$pretrained/$name$suffix
    fresh=0
    if [ "$epoch" -gt 0 ]; then
      args=(due --metrics "$dir/run/metrics.csv" --rescue "$rescue" --every "$rescue_every"
            --age "$rescue_age" --floor "$rescue_floor"
            --started "$(sed -n 's/^STARTED=//p' "$dir/keeper.env")")
      [ "$epoch" -lt "$(planned "$dir")" ] || args+=(--finished)
      verdict=$(python3 "$repo/scripts/long_runs_rescue.py" "${args[@]}")
      if [ "${verdict%%:*}" = write ]; then
        mkdir -p "$rescue"
        nice -n 5 "$fmsr" rescue "$dir/run" --keep "$keep" --out "$rescue/rescue.fmsr.tmp" > "$rescue/rescue.log" \
          || die "$name: fmsr rescue failed: $(cat "$rescue/rescue.log")"
        # The file names the epoch of the checkpoint it read: it must be the one counted.
        grep -q "epoch $epoch," "$rescue/rescue.log" || die "$name: the rescue point is not of epoch $epoch"
        mv "$rescue/rescue.fmsr.tmp" "$rescue/rescue.fmsr"
        printf 'EPOCH=%s\nKEEP=%s\nWRITTEN=%s\nSTARTED=%s\n' "$epoch" "$keep" "$(date -u +%FT%TZ)" \
          "$(sed -n 's/^STARTED=//p' "$dir/keeper.env")" > "$rescue/rescue.env"
        echo "$name: rescue point of epoch $epoch ($(du -h "$rescue/rescue.fmsr" | cut -f1)): ${verdict#write: }"
        fresh=1
      else
        echo "$name: ${verdict#skip: }"
      fi
    fi
    best=$(python3 "$repo/scripts/long_runs_final.py" best "$out" 2> /dev/null || true)
    snap=$dir/snapshots/epoch-$(printf %03d "${best:-0}").fmsr
    had=$(sed -n 's/^EPOCH=//p' "$pre/best_so_far.env" 2> /dev/null || true)
    if [ -n "$best" ] && [ -f "$snap" ] && [ "$had" != "$best" ]; then
      # With the rescue point, or the first one: each copy stays in git's history too.
      if [ "$fresh" = 1 ] || [ ! -f "$pre/best_so_far.fmsr" ]; then
        mkdir -p "$pre"
        cp "$snap" "$pre/best_so_far.fmsr.tmp"
        mv "$pre/best_so_far.fmsr.tmp" "$pre/best_so_far.fmsr"
        printf 'EPOCH=%s\nCHOSEN=%s\n' "$best" "\"best on the validation episodes among the snapshots recorded so far\"" \
          > "$pre/best_so_far.env"
        echo "$name: best on validation so far, epoch $best, in $pre/best_so_far.fmsr"
      else
        echo "$name: best on validation so far is epoch $best; $pre/best_so_far.fmsr keeps epoch ${had:-?} until the rescue point is rewritten"
      fi
    fi
  done
}

write_section() {
  python3 "$repo/scripts/long_runs_record.py" --home "$home" --results "$results" \
    --records "$records" --pretrained "$pretrained" --commit "$(git -C "$repo" rev-parse --short HEAD)" \
    --heading "$heading" --suffix "$suffix"
  report_again
}

# Builds the work tree's release binary with MuJoCo, the one every evaluation
# and rescue point of `record` and `finish` uses (a run trained on MuJoCo is
# evaluated on its own engine by default), and points $fmsr at it.
work_tree_binary() {
  cd "$repo"
  scripts/setup_mujoco.sh >&2
  cargo build --release --features mujoco --bin fmsr >&2
  export LD_LIBRARY_PATH=$repo/target/mujoco/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
  fmsr=$repo/target/release/fmsr
}

# One writer of the records, rescue points and pretrained/ at a time: a
# `finish` left running under nohup and the session's last `record` would
# evaluate the same snapshot into the same temporary files. The lock is the
# home's (fd 8, held until the script exits); a second one is refused.
records_writer() {
  # Files set aside for a GPU call (scripts/gpu/aside.sh) would be put back over what this writes.
  [ ! -f "$repo/.aside/MANIFEST" ] || die "tracked files are set aside for a GPU call: \`scripts/gpu/aside.sh back\` first"
  exec 8> "$home/records.lock"
  flock -n 8 || die "another \`$0 record\` or \`finish\` is writing the records (it holds $home/records.lock); wait for it"
}

record() {
  [ -d "$home" ] || die "no long-run home at $home (if it was lost, \`$0 lost\` records that and rewrites the section)"
  records_writer
  work_tree_binary
  evaluate_snapshots
  rescue_and_best
  write_section
  untracked_records
}

# Names what `record` wrote that git does not track yet (a snapshot's new
# evaluations, a rescue point written for the first time): `git commit -a`
# leaves those out, and the report written from them could not be
# recomputed from the repository.
untracked_records() {
  local new
  new=$(git -C "$repo" ls-files --others --exclude-standard -- "$records" "$pretrained" 2> /dev/null || true)
  [ -z "$new" ] || printf 'not yet in git (git add them with the rest):\n%s\n' "$new"
}

# The reproduction report reads the campaigns' records in the repository
# (docs/results/paper_budget, paper_stack; a campaign in progress by its
# snapshots): written again with the section, so that its test (CI) keeps
# matching them. Records kept elsewhere (FMSR_LONG_RUNS_RECORDS) leave it alone.
report_again() {
  case $records in
    "$repo"/docs/results/*) python3 "$repo/scripts/reproduction_report.py" ;;
  esac
}

# Writes $1 (an evaluation's JSON) with `fmsr eval ARGS... --out`, unless an
# earlier `finish` did; its output goes beside it as .log.
eval_once() {
  local json=$1
  shift
  [ -f "$json" ] && return
  echo "$(basename "$(dirname "$(dirname "$json")")") $(basename "$json" .json): fmsr eval $*"
  nice -n 5 "$fmsr" eval "$@" --out "$json.tmp" > "${json%.json}.log" 2>&1 || die "fmsr eval $* failed: ${json%.json}.log"
  mv "$json.tmp" "$json"
}

# Copies policy file $1 to $2 and writes into it its evaluations: the fixed
# test set and the validation episodes, each on both engines; unless $2 exists.
# The file shipped is at half precision (`fmsr export --precision half`: about
# half the bytes, which the tree needs), carrying its own evaluations, played
# again at that precision after those of the policy as trained. With $3, each
# evaluation also goes there as JSON (test-rapier.json, validation-rapier.json,
# test-mujoco.json, validation-mujoco.json: the policy as trained; the same
# names with -half: the file shipped, its .log saying how many episodes end
# otherwise). Every engine is named: `fmsr eval` without `--engine` takes the
# one the run trained on, which for the MuJoCo-trained pair would have put
# MuJoCo evaluations in the rapier files.
carry_evaluations() {
  local from=$1 to=$2 json=${3:-} what args pass name
  [ -f "$to" ] && return
  cp "$from" "$to.tmp.fmsr"
  for pass in full half; do
    if [ "$pass" = half ]; then
      "$fmsr" export "$to.tmp.fmsr" --precision half --out "$to.half.tmp.fmsr" > /dev/null 2>&1 \
        || die "fmsr export $from --precision half failed"
      mv "$to.half.tmp.fmsr" "$to.tmp.fmsr"
    fi
    for what in test-rapier validation-rapier test-mujoco validation-mujoco; do
      args=(--engine "${what#*-}")
      [ "${what%%-*}" = test ] || args+=(--set validation)
      name=$what
      [ "$pass" = full ] || name=$what-half
      if [ -n "$json" ]; then
        nice -n 5 "$fmsr" eval "$to.tmp.fmsr" "${args[@]}" --record --out "$json/$name.json.tmp" > "$json/$name.log" 2>&1 \
          || die "fmsr eval $to ${args[*]} failed: $json/$name.log"
        mv "$json/$name.json.tmp" "$json/$name.json"
      else
        nice -n 5 "$fmsr" eval "$to.tmp.fmsr" "${args[@]}" --record > /dev/null
      fi
    done
  done
  mv "$to.tmp.fmsr" "$to"
}

# The final evaluations and policies of one ended run (see the header).
finish_run() {
  local dir=$1 name out pre best last
  name=$(basename "$dir")
  out=$records/$name/final
  pre=$pretrained/$name$suffix
  # Ended by an earlier finish (`finish RUN`, or a bare one run again): its
  # best snapshot may be gone with the home, and best_so_far.fmsr with it.
  if finished_out "$records/$name"; then
    echo "$name: finished before ($(tr '\n' ' ' < "$out/finished.env"))"
    return
  fi
  mkdir -p "$out" "$pre"
  # shellcheck disable=SC1091
  (source "$dir/keeper.env"
   [ -f "$dir/final.fmsr" ] && exit 0
   "$BIN" export "$dir/run" --out "$dir/final.fmsr.tmp" | tee "$dir/final.log"
   grep -q "after $EPOCHS epochs" "$dir/final.log" || die "$name: the checkpoint is not the last epoch's"
   mv "$dir/final.fmsr.tmp" "$dir/final.fmsr")
  carry_evaluations "$dir/final.fmsr" "$pre/policy.fmsr" "$out"
  # The trials only as JSON: the file carries one test evaluation per engine, the 100.
  eval_once "$out/trials-rapier.json" "$dir/final.fmsr" --engine rapier --episodes "$trials"
  eval_once "$out/trials-mujoco.json" "$dir/final.fmsr" --engine mujoco --episodes "$trials"
  best=$(python3 "$repo/scripts/long_runs_final.py" best "$records/$name")
  last=$(($(planned "$dir") - 1))
  if [ "$best" != "$last" ]; then
    local snap=$dir/snapshots/epoch-$(printf %03d "$best").fmsr
    # A snapshot lost with a home (the run was restored from its rescue point)
    # is in pretrained/ when it was the best so far.
    if [ ! -f "$snap" ] && [ "$(sed -n 's/^EPOCH=//p' "$pre/best_so_far.env" 2> /dev/null)" = "$best" ]; then
      snap=$pre/best_so_far.fmsr
    fi
    [ -f "$snap" ] || die "$name: the snapshot of epoch $best, best on validation, is neither in the home nor in $pre"
    carry_evaluations "$snap" "$pre/best_on_validation.fmsr"
  fi
  # Test episode 0 on the engine the run trained on (`fmsr render`'s default).
  compgen -G "$pre/render/episode-0-*.gif" > /dev/null || nice -n 5 "$fmsr" render "$pre"
  python3 "$repo/scripts/long_runs_final.py" readme "$records/$name" "$pre" --commit "$(git rev-parse --short HEAD)" \
    --heading "$heading" --results "$results"
  # The run has ended: its rescue point and best policy so far are superseded
  # by policy.fmsr and best_on_validation.fmsr (history keeps them).
  rm -rf "$pre/rescue" "$pre/best_so_far.fmsr" "$pre/best_so_far.env"
  printf 'FINISHED=%s\nCOMMIT=%s\n' "$(date -u +%FT%TZ)" "$(git rev-parse --short HEAD)" > "$out/finished.env.tmp"
  mv "$out/finished.env.tmp" "$out/finished.env"
}

# `finish` with no names: every run, then the report and the comparison. With
# names: those runs alone (each must have ended), so a run that ends first is
# finished on the core it frees while the other trains; the report waits for
# the bare `finish`, which then counts a run finished earlier even when the
# home has lost it since (its policies are in pretrained/).
finish() {
  [ -d "$home" ] || die "no long-run home at $home"
  records_writer
  cd "$repo"
  local dir out name waiting=() chosen=() policies=()
  if [ $# -gt 0 ]; then
    for name in "$@"; do
      [ -f "$home/$name/keeper.env" ] || die "no run $name in $home (runs: $(runs | xargs -r -n 1 basename | tr '\n' ' '))"
      chosen+=("$home/$name")
    done
  else
    for dir in $(runs); do chosen+=("$dir"); done
    for out in $(recorded); do
      [ -f "$home/$(basename "$out")/keeper.env" ] || finished_out "$out" \
        || waiting+=("$(basename "$out") (recorded, neither in the home nor finished: \`$0 resume\` restores it)")
    done
  fi
  for dir in "${chosen[@]}"; do
    finished "$dir" || waiting+=("$(basename "$dir") ($(epochs_done "$dir") of $(planned "$dir") epochs)")
  done
  if [ ${#waiting[@]} -gt 0 ]; then
    [ $# -eq 0 ] || die "not every run named has ended: ${waiting[*]}"
    die "not every run has ended: ${waiting[*]}; finish waits for all (\`$0 finish RUN...\` finishes those that have)"
  fi
  # One build for every evaluation: rapier and MuJoCo alike.
  work_tree_binary
  evaluate_snapshots
  for dir in "${chosen[@]}"; do
    finish_run "$dir"
    [ $# -eq 0 ] || policies+=("$pretrained/$(basename "$dir")$suffix")
  done
  if [ $# -eq 0 ]; then
    for out in $(recorded); do policies+=("$pretrained/$(basename "$out")$suffix"); done
    nice -n 5 "$fmsr" report "${policies[@]}" --out "$records/report"
  fi
  write_section
  # What the policies add to the tracked tree (kept under 56 MiB: scripts/check_tree_size.sh).
  du -sh "${policies[@]}"
}

# Marks every recorded run the home does not hold as lost (lost.env in its
# records), then rewrites the section from the records.
lost() {
  cd "$repo"
  local out name now
  now=$(date -u +%FT%TZ)
  [ -n "$(recorded)" ] || die "no recorded run in $records"
  # Refuse before marking anything: a run the home holds is not lost.
  for out in $(recorded); do
    name=$(basename "$out")
    [ -f "$home/$name/keeper.env" ] || continue
    [ "$(sed -n 's/^STARTED=//p' "$home/$name/keeper.env")" = "$(sed -n 's/^STARTED=//p' "$out/keeper.env")" ] \
      && die "the home holds $name ($home/$name): it is not lost"
    die "the home holds a later run $name than the one recorded: \`$0 record\` moves the earlier record aside"
  done
  for out in $(recorded); do
    name=$(basename "$out")
    # A run `finish` ended needs no home: its policies are in pretrained/.
    if finished_out "$out"; then
      echo "$name: finished, not lost (its final policies are in $pretrained/$name$suffix)"
    elif [ -f "$out/lost.env" ]; then
      echo "$name: marked lost before ($(cat "$out/lost.env"))"
    else
      echo "FOUND=$now" > "$out/lost.env.tmp" && mv "$out/lost.env.tmp" "$out/lost.env"
      echo "$name: lost, its record stops at $( [ -f "$out/metrics.csv" ] && echo $(($(wc -l < "$out/metrics.csv") - 1)) || echo 0) epochs"
    fi
  done
  write_section
}

case "${1:-}" in
  start) shift; start "$@"; exit ;;
  resume) resume; exit ;;
  status) status; exit ;;
  record) record; exit ;;
  finish) shift; finish "$@"; exit ;;
  lost) lost; exit ;;
  _drive) drive "$2"; exit ;;
  *) die "usage: $0 start CONFIG... | resume | status | record | finish [RUN...] | lost" ;;
esac
