#!/usr/bin/env bash
# The restart twins (scripts/restart_twins.sh) end to end on a tiny egg run
# (Dense+FMSR+IS, rapier, 2 epochs of 2 episodes), in a scratch directory:
# the `uninterrupted` twin must be the run itself going on (its metrics equal,
# column for column but the clock's, to the same checkpoint resumed by hand:
# else the table would compare restarts with something else); each restart
# arm must restart from a rescue point of its KEEP with its REFILL, recorded
# in its restarts.jsonl; a source that is training (its lock held) and bad
# arms are refused before anything is copied; a second call trains nothing;
# a call to a later EPOCHS goes on from each arm's checkpoint, restarts an
# arm it adds at the split, and evaluates the new policies again.
#
#   scripts/test_restart_twins.sh      # under a minute with target/release/fmsr built (or FMSR_BIN)
#
# Not in CI: it needs a built binary, which CI's stages before it do not
# leave as a release build; the table's arithmetic is CI's `restart-twins` stage.
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
fmsr=${FMSR_BIN:-$repo/target/release/fmsr}
export LD_LIBRARY_PATH=$repo/target/mujoco/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
twins=$repo/scripts/restart_twins.sh
fail() { echo "test_restart_twins: FAILED: $*" >&2; exit 1; }
cd "$scratch"

cat > tiny.toml << 'EOF'
name = "egg_tiny"
method = "dense_fmsr_is"
engine = "rapier"

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
"$fmsr" train --config tiny.toml --out run --quiet > /dev/null
cp -a run reference
"$fmsr" train --out reference --resume --epochs 4 --quiet > /dev/null

# Refused before anything is copied: a source that trains, a bad arm, no reference.
# One process holds the lock (a shell's `sleep` child would keep it past a kill).
python3 -c 'import fcntl, sys, time; f = open("run/.lock"); fcntl.flock(f, fcntl.LOCK_EX); print(flush=True); time.sleep(60)' > held &
holder=$!
until [ -s held ]; do sleep 0.1; done
"$twins" run out 4 uninterrupted online 2> err && fail "twins started from a run whose lock is held"
grep -q "is training" err || fail "refused a locked source for another reason: $(cat err)"
kill "$holder"
wait "$holder" 2> /dev/null || true
"$twins" run out 4 uninterrupted bogus 2> err && fail "an arm named bogus was trained"
grep -q "arm \`bogus\`" err || fail "the bad arm is not named: $(cat err)"
"$twins" run out 4 online 2> err && fail "twins without the uninterrupted reference were trained"
grep -q "no \`uninterrupted\` arm" err || fail "the missing reference is not named: $(cat err)"
"$twins" run out 2 uninterrupted online 2> err && fail "twins to the checkpoint's own epoch were trained"
[ ! -e out/uninterrupted ] && [ ! -e out/split ] || fail "a refused call copied the source"

# To epoch 3 first, then on to 4: each arm goes on from its own checkpoint,
# and full:4, added by the second call, restarts from the split all the same.
FMSR_TWINS_JOBS=2 "$twins" run out 3 uninterrupted online > /dev/null
FMSR_TWINS_JOBS=2 "$twins" run out 4 uninterrupted online full:4 > table
grep -q "^EPOCH0=2$" out/twins.env || fail "twins.env: $(cat out/twins.env)"
[ "$(grep -c '^| \(uninterrupted\|online\|full-refill4\) |' table)" = 3 ] || fail "the table has not its three arms: $(cat table)"
cmp -s table out/twins.md || fail "the printed table is not OUT/twins.md"

# The split holds the rescue points and the run's small files, no copy of the run.
[ "$(ls out/split | tr '\n' ' ')" = "config.toml provenance.json rescue-full.fmsr rescue-half.fmsr rescue-online.fmsr rescue-targets.fmsr " ] \
  || fail "OUT/split: $(ls out/split)"
cmp -s run/provenance.json out/uninterrupted/provenance.json || fail "the uninterrupted twin lost the run's provenance.json"

# The uninterrupted twin is the run itself going on: every column but the clock's.
python3 - reference/metrics.csv out/uninterrupted/metrics.csv << 'EOF' || fail "the uninterrupted twin is not the run resumed"
import csv, sys
clock = {"seconds", "env_steps_per_sec", "updates_per_sec"}
a, b = (list(csv.DictReader(open(p))) for p in sys.argv[1:])
assert len(a) == len(b) == 4, (len(a), len(b))
for ra, rb in zip(a, b):
    for k in ra:
        if k not in clock:
            assert ra[k] == rb[k], (ra["epoch"], k, ra[k], rb[k])
EOF

# Each restart arm: its KEEP, its REFILL (default one epoch's: 1 cycle x 2 episodes), at the split.
python3 - out << 'EOF' || fail "the restart arms did not restart as their names say"
import json, sys
from pathlib import Path
out = Path(sys.argv[1])
for arm, keeps, refill in (("online", "online", 2), ("full-refill4", "full", 4)):
    r = [json.loads(l) for l in (out / arm / "restarts.jsonl").read_text().splitlines() if l.strip()]
    assert len(r) == 1, (arm, r)
    assert r[0]["restart"]["epoch"] == 2 and r[0]["restart"]["keeps"] == keeps, (arm, r[0]["restart"])
    assert r[0]["restart"]["refill_episodes"] == refill, (arm, r[0]["restart"])
assert not (out / "uninterrupted" / "restarts.jsonl").exists()
EOF

# The last call evaluated the policies of epoch 4, not kept those of epoch 3.
for arm in uninterrupted online full-refill4; do
  [ ! out/$arm/checkpoint.bin -nt out/$arm/eval.json ] || fail "$arm: eval.json is older than its last checkpoint"
done

# A second call trains nothing and writes the same table.
before=$(stat -c %Y out/*/metrics.csv out/*/eval.json)
"$twins" run out 4 uninterrupted online full:4 > again
[ "$(stat -c %Y out/*/metrics.csv out/*/eval.json)" = "$before" ] || fail "a second call trained or evaluated again"
cmp -s table again || fail "a second call wrote another table"
echo "test_restart_twins: ok"
