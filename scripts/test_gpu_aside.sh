#!/usr/bin/env bash
# Guards scripts/gpu/aside.sh (issue 53, item 1): the tracked files a GPU call
# does not need (rescue points, files of a MiB or more) leave the tree and
# git's index for the call, and come back as they were, index entries
# included (a staged change too); a second `away` is refused, a `record` of
# the long runs is refused while files are aside, a file written in the
# meantime is never overwritten, and an `away` cut off after some moves is
# undone by `back`. In a scratch repository; no build, a few seconds (CI
# stage gpu-aside).
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
fail() { echo "test_gpu_aside: FAILED: $*" >&2; exit 1; }

r=$scratch/r
mkdir -p "$r/scripts/gpu" "$r/pretrained/big" "$r/docs/results/run/rescue" "$r/src"
cp "$repo/scripts/gpu/aside.sh" "$r/scripts/gpu/"
cp "$repo/scripts/long_runs.sh" "$r/scripts/"
cd "$r"
git init -q
git config user.email test@example.invalid
git config user.name test
printf '/.aside/\n' > .gitignore
head -c 2200000 /dev/urandom > pretrained/big/policy.fmsr
head -c 1100000 /dev/urandom > "pretrained/big/with space.gif"
head -c 40000 /dev/urandom > docs/results/run/rescue/rescue.fmsr
printf 'EPOCH=3\n' > docs/results/run/rescue/rescue.env
echo "fn main() {}" > src/main.rs
head -c 500000 /dev/urandom > pretrained/small.fmsr
git add -A
git commit -q -m base
# A staged change to a large file and an unstaged one to a small file: both survive.
head -c 1300000 /dev/urandom > pretrained/big/policy.fmsr
git add pretrained/big/policy.fmsr
echo "// edited" >> src/main.rs
status_before=$(git status --porcelain)
index_before=$(git ls-files -s)
sums_before=$(git ls-files -z | xargs -0 sha256sum)

scripts/gpu/aside.sh away > "$scratch/away" || fail "away: $(cat "$scratch/away")"
grep -q "set aside 4 files" "$scratch/away" || fail "away: $(cat "$scratch/away")"
for f in pretrained/big/policy.fmsr "pretrained/big/with space.gif" docs/results/run/rescue/rescue.fmsr docs/results/run/rescue/rescue.env; do
  [ ! -e "$f" ] || fail "$f is still in the tree"
  [ -f ".aside/files/$f" ] || fail "$f is not in .aside/files"
  git ls-files --error-unmatch -- "$f" > /dev/null 2>&1 && fail "$f is still in the index"
done
travels=$(git ls-files --cached --others --exclude-standard)
[ "$(echo "$travels" | sort | tr '\n' ' ')" = ".gitignore pretrained/small.fmsr scripts/gpu/aside.sh scripts/long_runs.sh src/main.rs " ] \
  || fail "what a copy of the tree would carry: $travels"
scripts/gpu/aside.sh status > "$scratch/status"
grep -q "aside: 4 files" "$scratch/status" || fail "status: $(cat "$scratch/status")"
scripts/gpu/aside.sh away 2> "$scratch/again" && fail "a second away ran"
grep -q "files are aside already" "$scratch/again" || fail "the second away: $(cat "$scratch/again")"
mkdir -p "$scratch/home"
FMSR_LONG_RUNS=$scratch/home scripts/long_runs.sh record 2> "$scratch/record" && fail "record ran while files are aside"
grep -q "set aside for a GPU call" "$scratch/record" || fail "record's refusal: $(cat "$scratch/record")"
[ ! -e "$scratch/home/records.lock" ] || fail "record took the lock before it refused"

# A file written where one is aside: `back` refuses and keeps both.
echo "new" > "pretrained/big/with space.gif"
scripts/gpu/aside.sh back 2> "$scratch/conflict" && fail "back overwrote a file written while it was aside"
grep -q "was written while it was aside" "$scratch/conflict" || fail "back's refusal: $(cat "$scratch/conflict")"
for f in "pretrained/big/with space.gif" docs/results/run/rescue/rescue.env pretrained/big/policy.fmsr; do
  [ -f ".aside/files/$f" ] || fail "back moved $f though it refused"
done
rm "pretrained/big/with space.gif"

# An `away` cut off after its first move, as `back` sees it: one file already where it was.
cp .aside/files/docs/results/run/rescue/rescue.env docs/results/run/rescue/rescue.env
scripts/gpu/aside.sh back > "$scratch/back" || fail "back: $(cat "$scratch/back")"
grep -q "put back 4 files" "$scratch/back" || fail "back: $(cat "$scratch/back")"
[ ! -e .aside ] || fail "back left .aside"
[ "$(git status --porcelain)" = "$status_before" ] || fail "git status after back: $(git status --porcelain)"
[ "$(git ls-files -s)" = "$index_before" ] || fail "the index after back differs"
[ "$(git ls-files -z | xargs -0 sha256sum)" = "$sums_before" ] || fail "the files after back differ"
scripts/gpu/aside.sh back 2> /dev/null && fail "back ran with nothing aside"

# A threshold: 0 MiB would take every file; a word is refused.
scripts/gpu/aside.sh away MiB 2> "$scratch/word" && fail "away took a word for MiB"
grep -q "whole number of MiB" "$scratch/word" || fail "away's refusal: $(cat "$scratch/word")"
echo "test_gpu_aside: passed"
