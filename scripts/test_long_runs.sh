#!/usr/bin/env bash
# The keeper of long runs (scripts/long_runs.sh), end to end on a scratch home:
# two tiny egg runs (Dense+FMSR+IS and Dense, 2 epochs of 2 episodes) are
# started, must both end with their snapshot, `resume` must leave them alone,
# a driver must wait for a lock held an instant (and train a third epoch),
# `lost` must mark them only once their home is gone, `record` must write
# rescue points only for runs with epochs left and keep them until a day of
# training (or a day by the clock and an hour of it) has passed, `resume` must
# restore the runs from them when the home is gone,
# `finish` must refuse while a run is unfinished, `finish RUN` must end one
# run ahead of the other, and the bare `finish` then write every final
# evaluation (each on the engine its name says), policy, README, report and the
# section with the paper's rows, and drop the rescue points of ended runs.
# The records, policies and section are a campaign's (the header of
# scripts/long_runs.sh): here the current one's suffix, heading and markers.
# Both runs train on MuJoCo, as the paper-budget pair does: `fmsr eval` without
# `--engine` takes the trained-on engine, and until 2026-11-29 `finish` relied
# on it being rapier. Nothing of the real home, docs/ or pretrained/ is touched.
#
#   scripts/test_long_runs.sh      # about 4 minutes with target/release built; needs a clean tree (start's rule)
#
# Not in CI: `start` and `finish` build release binaries with `--features
# mujoco`, which CI's debug build does not give. Run it when the
# keeper changes. It guards, among others, the race of 2026-11-26: the
# launcher's liveness probe took the lock for an instant and a driver that
# met it gave up, leaving its run stopped.
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
scratch=$(mktemp -d)
# The drivers of a failed test must not outlive it.
trap 'pkill -f "$scratch/home" 2> /dev/null || true; rm -rf "$scratch"' EXIT
# The records directory's name gives the markers of the section, summary and policy index: paper-stack.
export FMSR_LONG_RUNS=$scratch/home FMSR_LONG_RUNS_RECORDS=$scratch/paper_stack \
  FMSR_LONG_RUNS_PRETRAINED=$scratch/pretrained FMSR_LONG_RUNS_RESULTS=$scratch/results.md \
  FMSR_LONG_RUNS_TRIALS=20
keeper=$repo/scripts/long_runs.sh
fail() { echo "test_long_runs: FAILED: $*" >&2; exit 1; }

for m in dense_fmsr_is dense; do
  cat > "$scratch/egg_$m.toml" << EOF
name = "egg_$m"
method = "$m"
engine = "mujoco"

[env]
object = "egg"
success_threshold = 0.1

[trainer]
seed = 0
epochs = 2
cycles = 1
episodes_per_cycle = 2
eval_episodes = 2

[replay]
batches = 2
batch_size = 32
buffer_size = 10000

[networks]
hidden = 32
layers = 2

[eval]
episodes = 10
threshold = 0.4
EOF
done
printf '# Results\n\n<!-- paper-stack-summary:begin (written by scripts/long_runs.sh record) -->\n<!-- paper-stack-summary:end -->\n' \
  > "$scratch/results.md"
mkdir -p "$scratch/pretrained"
printf '# Policies\n\n<!-- paper-stack-policies:begin (written by scripts/long_runs.sh finish) -->\n<!-- paper-stack-policies:end -->\n' \
  > "$scratch/pretrained/README.md"

"$keeper" start "$scratch/egg_dense_fmsr_is.toml" "$scratch/egg_dense.toml"
"$keeper" finish 2> "$scratch/refused" && fail "finish ran before the runs ended"
grep -q "not every run has ended" "$scratch/refused" || fail "finish refused for another reason: $(cat "$scratch/refused")"
for _ in $(seq 600); do
  "$keeper" status > "$scratch/status"
  grep -q alive "$scratch/status" || break
  sleep 1
done
"$keeper" status
for run in egg_dense_fmsr_is egg_dense; do
  [ -f "$FMSR_LONG_RUNS/$run/snapshots/epoch-000.fmsr" ] || fail "$run: no snapshot of epoch 0 ($(cat "$FMSR_LONG_RUNS/$run/keeper.log"))"
  grep -q "finished: 2 of 2 epochs" "$FMSR_LONG_RUNS/$run/keeper.log" || fail "$run did not finish: $(cat "$FMSR_LONG_RUNS/$run/keeper.log")"
done
"$keeper" resume > "$scratch/resumed"
[ "$(grep -c "finished (2 epochs)" "$scratch/resumed")" = 2 ] || fail "resume did not see both runs finished"

# A driver that meets a probe of its lock (`alive` holds it for an instant)
# waits rather than leaving its run stopped: hold the lock for a second while a
# driver starts on a run given one epoch more.
dir=$FMSR_LONG_RUNS/egg_dense
sed -i 's/^EPOCHS=2$/EPOCHS=3/' "$dir/keeper.env"
flock "$dir/keeper.lock" sleep 1 &
sleep 0.2
bash "$dir/keeper.sh" _drive "$dir" >> "$dir/keeper.log" 2>&1
wait
grep -q "finished: 3 of 3 epochs" "$dir/keeper.log" || fail "a driver meeting a held lock gave up: $(tail -n 3 "$dir/keeper.log")"

# A home found gone (a machine not kept, 2026-11-25 and 2026-11-27): `lost`
# refuses while the home holds the runs, then marks them and says so in the
# section, `resume` points at it, and a `record` that finds the runs in the
# home after all removes the mark.
"$keeper" record
"$keeper" lost 2> "$scratch/refused" && fail "lost ran while the home holds the runs"
grep -q "it is not lost" "$scratch/refused" || fail "lost refused for another reason: $(cat "$scratch/refused")"
# With one run gone and the other held, nothing is marked (6cd1bf0: the first was).
mv "$FMSR_LONG_RUNS/egg_dense" "$scratch/egg_dense.kept"
"$keeper" lost 2> "$scratch/refused" && fail "lost ran while the home holds egg_dense_fmsr_is"
[ ! -e "$FMSR_LONG_RUNS_RECORDS/egg_dense/lost.env" ] || fail "lost marked egg_dense before it refused"
mv "$scratch/egg_dense.kept" "$FMSR_LONG_RUNS/egg_dense"
# Both runs had trained all their epochs at that `record`: it wrote no rescue
# point (`finish` ends them), only the best snapshots so far. Records without
# rescue points: `resume` cannot restore them and points at `lost`. (`record`
# writes them below, once the runs have epochs left.)
for run in egg_dense_fmsr_is egg_dense; do
  [ ! -e "$FMSR_LONG_RUNS_PRETRAINED/${run}_paper_stack/rescue" ] || fail "$run: record wrote a rescue point of a run that had trained all its epochs"
  [ -s "$FMSR_LONG_RUNS_PRETRAINED/${run}_paper_stack/best_so_far.fmsr" ] || fail "$run: record kept no best policy so far (the first is copied at once)"
done
mv "$FMSR_LONG_RUNS" "$scratch/home.kept"
"$keeper" resume > "$scratch/resumed"
grep -q "not in the home: egg_dense egg_dense_fmsr_is; if the home was lost" "$scratch/resumed" || fail "resume did not point at lost: $(cat "$scratch/resumed")"
"$keeper" lost
for run in egg_dense_fmsr_is egg_dense; do
  grep -q "^FOUND=" "$FMSR_LONG_RUNS_RECORDS/$run/lost.env" || fail "$run: not marked lost"
done
grep -q '^\*\*Lost before the end.\*\* The keeper' "$scratch/results.md" || fail "the section does not say the runs were lost"
grep -q "lost with their machine; recorded to 2 of 2 and 3 of 3 epochs" "$scratch/results.md" || fail "the summary line does not say the runs were lost"
"$keeper" resume | grep -q "not in the home" && fail "resume still points at runs marked lost"
mv "$scratch/home.kept" "$FMSR_LONG_RUNS"
# Each run one epoch short of its plan (a session ended them there): `record`
# writes their rescue points, pretrained/ having none.
sed -i 's/^EPOCHS=2$/EPOCHS=3/' "$FMSR_LONG_RUNS/egg_dense_fmsr_is/keeper.env"
sed -i 's/^EPOCHS=3$/EPOCHS=4/' "$FMSR_LONG_RUNS/egg_dense/keeper.env"
"$keeper" record
[ ! -e "$FMSR_LONG_RUNS_RECORDS/egg_dense/lost.env" ] || fail "record left the mark on a run the home holds"
grep -q "Lost before" "$scratch/results.md" && fail "the section still says the runs were lost"
# A rescue point is rewritten after a day of training, not at every `record`.
for run in egg_dense_fmsr_is egg_dense; do cp "$FMSR_LONG_RUNS_PRETRAINED/${run}_paper_stack/rescue/rescue.env" "$scratch/$run.rescue.env"; done
"$keeper" record > "$scratch/recorded"
for run in egg_dense_fmsr_is egg_dense; do
  cmp -s "$FMSR_LONG_RUNS_PRETRAINED/${run}_paper_stack/rescue/rescue.env" "$scratch/$run.rescue.env" || fail "$run: record rewrote a rescue point with no training since"
  grep -q "^$run: rescue point of epoch [0-9]* kept: 0.0 h of training since it" "$scratch/recorded" || fail "$run: record does not say it kept the rescue point: $(cat "$scratch/recorded")"
done

# A home lost for good (issue 53): `record` wrote each run's rescue point and
# its best policy so far; with the home gone, `resume` restores both runs from
# their rescue points (this tree's build), the drivers restart from them, and
# the restart is in the run's restarts.jsonl, the records and the section.
for run in egg_dense_fmsr_is egg_dense; do
  [ -s "$FMSR_LONG_RUNS_PRETRAINED/${run}_paper_stack/rescue/rescue.fmsr" ] || fail "$run: record wrote no rescue point"
  grep -q '^KEEP=half$' "$FMSR_LONG_RUNS_PRETRAINED/${run}_paper_stack/rescue/rescue.env" || fail "$run: no rescue.env"
  [ -s "$FMSR_LONG_RUNS_PRETRAINED/${run}_paper_stack/best_so_far.fmsr" ] || fail "$run: record kept no best policy so far"
done
mv "$FMSR_LONG_RUNS" "$scratch/home.lost"
# A snapshot the lost home took after the rescue point: its
# evaluation is of a trajectory the restored run does not follow, so resume
# sets it aside with the metrics of the loss, and keeps those of earlier epochs.
echo '{}' > "$FMSR_LONG_RUNS_RECORDS/egg_dense/snapshots/epoch-099.test.json"
"$keeper" resume > "$scratch/resumed"
[ "$(grep -c "restored from its rescue point" "$scratch/resumed")" = 2 ] || fail "resume did not restore both runs: $(cat "$scratch/resumed")"
[ ! -e "$FMSR_LONG_RUNS_RECORDS/egg_dense/snapshots/epoch-099.test.json" ] || fail "resume kept a lost trajectory's snapshot among the run's"
ls "$FMSR_LONG_RUNS_RECORDS"/egg_dense/lost-*/snapshots/epoch-099.test.json > /dev/null || fail "resume did not set the lost snapshot aside"
ls "$FMSR_LONG_RUNS_RECORDS"/egg_dense/snapshots/epoch-000.test.json > /dev/null || fail "resume set aside a snapshot from before the rescue point"
epoch=$(sed -n 's/^EPOCH=//p' "$FMSR_LONG_RUNS_PRETRAINED/egg_dense_paper_stack/rescue/rescue.env")
grep -q "^egg_dense: the records of epochs $epoch on, trained on the lost home, set aside" "$scratch/resumed" || fail "resume does not say what it set aside (epoch $epoch): $(cat "$scratch/resumed")"
# It says where the drivers restart, not "epoch 0" (no checkpoint yet; fixed 2026-12-01).
for run in egg_dense_fmsr_is egg_dense; do
  epoch=$(sed -n 's/^EPOCH=//p' "$FMSR_LONG_RUNS_PRETRAINED/${run}_paper_stack/rescue/rescue.env")
  grep -q "^$run: started from its rescue point of epoch $epoch " "$scratch/resumed" || fail "resume does not say where $run restarts (epoch $epoch): $(cat "$scratch/resumed")"
done
for _ in $(seq 600); do
  "$keeper" status > "$scratch/status"
  grep -q alive "$scratch/status" || break
  sleep 1
done
for run in egg_dense_fmsr_is egg_dense; do
  grep -q '"refill_episodes"' "$FMSR_LONG_RUNS/$run/run/restarts.jsonl" || fail "$run: no restart recorded ($(tail -n 5 "$FMSR_LONG_RUNS/$run/keeper.log"))"
  grep -q '"buffer_episodes"' "$FMSR_LONG_RUNS/$run/run/restarts.jsonl" || fail "$run: the restart does not count the buffer it lost"
  [ -f "$FMSR_LONG_RUNS/$run/run/checkpoint.bin" ] || fail "$run: the restarted run has no checkpoint"
  grep -q '^BIN_NOTE=' "$FMSR_LONG_RUNS/$run/keeper.env" || fail "$run: keeper.env does not say which binary restored it"
done
"$keeper" record
grep -q "Restarted at epoch 2 from its rescue point (kept \`half\`" "$scratch/results.md" || fail "the section does not show the restart"
# And what it cost, n/a here: 10 epochs on either side are not trained (the table since 2026-12-01).
grep -q "^| Dense+FMSR+IS | 2 | n/a | n/a |" "$scratch/results.md" || fail "the section has no row for the restart in its restart table"
# What it lost is the buffer's content, not every episode of the run (fixed 2026-11-29).
grep -q "lost the replay buffer ([0-9]* episodes of the [0-9]* stored over the run)" "$scratch/results.md" || fail "the section does not count the buffer a restart lost"
# A restored run's binary is the restore's, said without the env file's quotes (fixed 2026-11-29).
grep -q 'since its restore: restored .* from the rescue point of epoch 2 with the build of' "$scratch/results.md" || fail "the section does not name the restore's binary"
! grep -q 'kept for the whole run' "$scratch/results.md" || fail "the section says a restored run kept its binary"
[ -f "$FMSR_LONG_RUNS_RECORDS/egg_dense_fmsr_is/restarts.jsonl" ] || fail "record did not copy the restarts"

# One writer of the records: a record or finish while another holds the lock is refused.
flock "$FMSR_LONG_RUNS/records.lock" sleep 3 &
sleep 0.5
"$keeper" record 2> "$scratch/refused" && fail "record ran while another writer held the records"
grep -q "is writing the records" "$scratch/refused" || fail "record refused for another reason: $(cat "$scratch/refused")"
wait

# A run finished ahead of the other (issue 53: Dense ends first, and its core is
# free while Dense+FMSR+IS trains on). `finish RUN` refuses a name the home
# lacks and a run that has not ended, then writes that run's final evaluations
# and policies alone, with no report; the bare `finish` later counts it, even
# after the home has lost it.
records=$FMSR_LONG_RUNS_RECORDS pre=$FMSR_LONG_RUNS_PRETRAINED
"$keeper" finish egg_nope 2> "$scratch/refused" && fail "finish ran for a run the home lacks"
grep -q "no run egg_nope in " "$scratch/refused" || fail "finish egg_nope refused for another reason: $(cat "$scratch/refused")"
sed -i 's/^EPOCHS=3$/EPOCHS=4/' "$FMSR_LONG_RUNS/egg_dense_fmsr_is/keeper.env"
"$keeper" finish egg_dense_fmsr_is 2> "$scratch/refused" && fail "finish ran for a run that has not ended"
grep -q "not every run named has ended: egg_dense_fmsr_is (3 of 4 epochs)" "$scratch/refused" || fail "finish egg_dense_fmsr_is refused for another reason: $(cat "$scratch/refused")"
"$keeper" finish 2> "$scratch/refused" && fail "finish ran for both with one not ended"
grep -q "finish RUN\.\.\.\` finishes those that have" "$scratch/refused" || fail "finish does not point at finish RUN: $(cat "$scratch/refused")"
sed -i 's/^EPOCHS=4$/EPOCHS=3/' "$FMSR_LONG_RUNS/egg_dense_fmsr_is/keeper.env"
"$keeper" finish egg_dense
grep -q '^FINISHED=' "$records/egg_dense/final/finished.env" || fail "finish egg_dense did not mark it finished"
[ -s "$pre/egg_dense_paper_stack/policy.fmsr" ] || fail "finish egg_dense wrote no final policy"
[ ! -e "$pre/egg_dense_paper_stack/rescue" ] || fail "finish egg_dense kept its rescue point"
[ ! -e "$records/egg_dense_fmsr_is/final" ] || fail "finish egg_dense evaluated egg_dense_fmsr_is"
[ -s "$pre/egg_dense_fmsr_is_paper_stack/rescue/rescue.fmsr" ] || fail "finish egg_dense dropped egg_dense_fmsr_is's rescue point"
[ ! -e "$records/report" ] || fail "finish egg_dense wrote the report"
grep -q '### At the end: against the paper' "$scratch/results.md" && fail "the section compares the final policies before both ended"
grep -q "the final evaluations and policies of the runs that have ended are written: Dense (in " "$scratch/results.md" || fail "the section does not say Dense's final evaluations are written"
# The home loses both runs: resume restores the one not finished, even with an
# evaluation of a `finish` cut off in its records (until 2026-12-02 the first
# final evaluation alone counted a run finished, and resume passed it over),
# neither restores the finished one nor calls it missing; record leaves that
# one as it is and does not mark it lost.
mv "$FMSR_LONG_RUNS/egg_dense" "$scratch/egg_dense.finished"
mv "$FMSR_LONG_RUNS/egg_dense_fmsr_is" "$scratch/egg_dense_fmsr_is.lost"
mkdir -p "$records/egg_dense_fmsr_is/final"
cp "$records/egg_dense/final/test-rapier.json" "$records/egg_dense_fmsr_is/final/test-rapier.json"
"$keeper" resume > "$scratch/resumed"
grep -q "^egg_dense_fmsr_is: restored from its rescue point" "$scratch/resumed" || fail "resume did not restore the run a finish was cut off in: $(cat "$scratch/resumed")"
grep -q "egg_dense: restored" "$scratch/resumed" && fail "resume restored a finished run: $(cat "$scratch/resumed")"
grep -q "not in the home" "$scratch/resumed" && fail "resume calls a finished run missing: $(cat "$scratch/resumed")"
for _ in $(seq 600); do
  "$keeper" status > "$scratch/status"
  grep -q alive "$scratch/status" || break
  sleep 1
done
"$keeper" record
[ ! -e "$pre/egg_dense_paper_stack/rescue" ] || fail "record wrote a rescue point of a finished run"
[ ! -e "$records/egg_dense/lost.env" ] || fail "record marked a finished run lost"
cp "$records/egg_dense/final/finished.env" "$scratch/finished.env"
"$keeper" finish
# Again with the finished run back in the home: it passes over egg_dense's
# finish_run (it restored from the rescue point and lost its best snapshot, and
# the first finish removed best_so_far.fmsr: until this was found, a second finish failed here).
mv "$scratch/egg_dense.finished" "$FMSR_LONG_RUNS/egg_dense"
"$keeper" finish
cmp -s "$records/egg_dense/final/finished.env" "$scratch/finished.env" || fail "a later finish rewrote egg_dense's finished.env"
for run in egg_dense_fmsr_is egg_dense; do
  for f in test-rapier validation-rapier test-mujoco validation-mujoco trials-rapier trials-mujoco; do
    [ -s "$FMSR_LONG_RUNS_RECORDS/$run/final/$f.json" ] || fail "$run: no final evaluation $f"
    # The engine and set the file's name says, of a policy trained on MuJoCo.
    python3 -c "import json,sys; e=json.load(open(sys.argv[1])); n=sys.argv[2]
want=({'trials': 'test'}.get(n.split('-')[0], n.split('-')[0]), n.split('-')[1], 'mujoco')
assert (e['set'], e['engine'], e['trained_on']) == want, (n, e['set'], e['engine'], e['trained_on'])" \
      "$FMSR_LONG_RUNS_RECORDS/$run/final/$f.json" "$f" || fail "$run: final/$f.json is not what its name says"
  done
  python3 -c "import json,sys; e=json.load(open(sys.argv[1])); assert e['episodes'] == 20, e['episodes']" \
    "$FMSR_LONG_RUNS_RECORDS/$run/final/trials-rapier.json" || fail "$run: the trials are not 20 episodes"
  for f in policy.fmsr best_on_validation.fmsr README.md render/episode-0-mujoco.gif; do
    [ -s "$FMSR_LONG_RUNS_PRETRAINED/${run}_paper_stack/$f" ] || fail "$run: no pretrained/${run}_paper_stack/$f"
  done
  # An ended run needs no rescue point; the tree would not hold it beside the final policies.
  for f in rescue best_so_far.fmsr best_so_far.env; do
    [ ! -e "$FMSR_LONG_RUNS_PRETRAINED/${run}_paper_stack/$f" ] || fail "$run: finish left pretrained/${run}_paper_stack/$f"
  done
  grep -q "| fixed test set, MuJoCo (trained on) |" "$FMSR_LONG_RUNS_PRETRAINED/${run}_paper_stack/README.md" || fail "$run: the README does not lead with MuJoCo"
  # The exported policy is shipped at half precision and carries its own
  # evaluations at that precision: eval repeats the test one.
  "$repo/target/release/fmsr" eval "$FMSR_LONG_RUNS_PRETRAINED/${run}_paper_stack" > "$scratch/eval"
  grep -q "the same results as the evaluation the file carries" "$scratch/eval" || fail "$run: the policy does not carry its test evaluation"
  grep -q "actors at half precision" "$scratch/eval" || fail "$run: the shipped policy is not at half precision"
  for f in test-rapier validation-rapier test-mujoco validation-mujoco; do
    python3 -c "import json,sys; e=json.load(open(sys.argv[1])); assert e.get('precision') == 'half', e.get('precision')" \
      "$FMSR_LONG_RUNS_RECORDS/$run/final/$f-half.json" || fail "$run: final/$f-half.json is not the half file's"
    python3 -c "import json,sys; e=json.load(open(sys.argv[1])); assert 'precision' not in e, e['precision']" \
      "$FMSR_LONG_RUNS_RECORDS/$run/final/$f.json" || fail "$run: final/$f.json is not the policy as trained"
  done
  grep -q "Success, the file shipped (f16)" "$FMSR_LONG_RUNS_PRETRAINED/${run}_paper_stack/README.md" || fail "$run: the README has no column for the file shipped"
done
# Twice at epoch 2: the restore above, then the one after the cut-off finish.
grep -q "Restarted from its rescue point at epochs 2, 2 " "$FMSR_LONG_RUNS_PRETRAINED/egg_dense_fmsr_is_paper_stack/README.md" || fail "the README does not say where the run was restored"
grep -q "seed 0, trained on MuJoCo;" "$scratch/results.md" || fail "the section does not say the runs trained on MuJoCo"
# A restored run's README names the restore's build (until 2026-12-02 it said "the run's own binary").
grep -q "exported by the binary the run ended with (\`fmsr-.*\`: restored .* from the rescue point of epoch 2 with the build of" \
  "$FMSR_LONG_RUNS_PRETRAINED/egg_dense_fmsr_is_paper_stack/README.md" || fail "the README does not name the restore's binary"
# An ended pair's section is no longer progress (until 2026-12-02 it still said so after finish).
grep -Eq "this section is progress, not a result|In progress and one seed each|best on validation so far" "$scratch/results.md" \
  && fail "the section of runs that have ended still calls itself in progress"
grep -q "Both runs have ended: the final comparison is at the end of this section" "$scratch/results.md" \
  || fail "the section of runs that have ended does not say so"
[ -s "$FMSR_LONG_RUNS_RECORDS/report/summary.md" ] || fail "no report"
# Over both policies, egg_dense's too, finished earlier and gone from the home.
grep -q "^2 run(s) over 1 task(s)" "$FMSR_LONG_RUNS_RECORDS/report/summary.md" || fail "the report is not over both runs: $(head -n 3 "$FMSR_LONG_RUNS_RECORDS/report/summary.md")"
# A `record` after `finish` (the next session's last step) brings back no rescue point.
"$keeper" record
for run in egg_dense_fmsr_is egg_dense; do
  for f in rescue best_so_far.fmsr; do
    [ ! -e "$FMSR_LONG_RUNS_PRETRAINED/${run}_paper_stack/$f" ] || fail "$run: record after finish wrote pretrained/${run}_paper_stack/$f again"
  done
done
for engine in MuJoCo rapier; do
  grep -q "The paper's orderings, Dense+FMSR+IS against Dense, $engine" "$scratch/results.md" || fail "no comparison with the paper on $engine"
  grep -q "How close the test episodes ended to their goals, $engine" "$scratch/results.md" || fail "no precision of the final policies on $engine"
done
grep -q "| Snapshot | Dense+FMSR+IS median angle |" "$scratch/results.md" || fail "no precision of the snapshots"
grep -q "on the fixed test set on MuJoCo (the engine they trained on)" "$scratch/results.md" || fail "the summary line is not on the trained-on engine"
grep -q "With the paper's stack at the paper's budget (3 epochs), egg, seed 0, ended" "$scratch/results.md" || fail "no summary line"
grep -q "| \[\`egg_dense_paper_stack\`\](egg_dense_paper_stack/README.md) | Dense, 6 agents | [0-9]* | MuJoCo |" "$scratch/pretrained/README.md" || fail "no row in pretrained/README.md"
# Without FMSR_LONG_RUNS_RESULTS the section goes into the records' README.md, created with a line above it.
FMSR_LONG_RUNS_RESULTS='' "$keeper" record > /dev/null
head -n 1 "$FMSR_LONG_RUNS_RECORDS/README.md" | grep -q "^The long runs of \`scripts/long_runs.sh\`" || fail "no line above the section in the records' README.md"
grep -q "^## The paper's stack at the paper's budget: the egg, Dense+FMSR+IS against Dense, 400 epochs$" "$FMSR_LONG_RUNS_RECORDS/README.md" \
  || fail "the records' README.md has no section under the campaign's heading"
echo "test_long_runs: passed"
