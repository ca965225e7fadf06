#!/usr/bin/env bash
# The GPU lease's scripts (scripts/gpu/) end to end on a machine without a GPU,
# with a `--cpu` pack: pack.sh packs the binaries, the model and cubecl's
# autotune results from an earlier lease; lease.sh, given a bench that runs
# out of time and no device but the CPU, starts both block runs, stops them,
# runs finish.sh and brings back the runs' archive and the autotune results
# that env.sh put back; FMSR_LEASE_FINISH=0 leaves the runs training;
# cubecl_first_use.py counts a small cubecl log right. A lease costs device
# time that sessions rarely get: these guard what a lease cannot afford to
# find out there, among them the step limit of 2026-11-26 that made a bench's
# timing cost the whole device (its parity check is read before its exit
# status now) and the second part of an archive that did not fit one call.
#
#   scripts/test_gpu_scripts.sh     # about 6 minutes on 2 cores with target/ built
#
# Not in CI: pack.sh builds release binaries, which CI's debug build does not
# give. Run it when scripts/gpu/ changes. It builds the default features into
# target/release, as `cargo build --release` does.
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
cd "$repo"
scratch=$(mktemp -d)
pack=.gpu-test-$$
kept=$scratch/environment.kept
cleanup() {
  for p in runs/gpu/*.pid; do [ -f "$p" ] && kill -TERM "$(cat "$p")" 2> /dev/null || true; done
  [ -f .aside/MANIFEST ] && scripts/gpu/aside.sh back > /dev/null
  rm -rf "$pack" runs/gpu target/environment
  [ -d "$kept" ] && mv "$kept" target/environment
  rm -rf "$scratch"
}
fail() { echo "test_gpu_scripts: FAILED: $*" >&2; exit 1; }
# Before the cleanup is armed: it removes runs/gpu, which must then be the test's own.
[ -e runs/gpu ] && fail "runs/gpu exists: the test trains there (move it away first)"
trap cleanup EXIT
# cubecl's results of this machine, if any, are set aside: the test's must be the ones restored.
[ -d target/environment ] && mv target/environment "$kept"

# An earlier lease's autotune results (a marker, not cubecl's database).
mkdir -p "$scratch/cache/environment"
echo "from an earlier lease" > "$scratch/cache/environment/fmsr-test-marker"
tar czf "$scratch/cubecl_cache.tar.gz" -C "$scratch/cache" environment
# Packed as the README does it, with the rescue points and policies set aside
# (scripts/gpu/aside.sh): the manifest says so and does not call them changes.
clean=0
git diff --quiet HEAD -- . ':!docs' && clean=1
[ -e .aside ] && fail ".aside exists: \`scripts/gpu/aside.sh back\` first"
scripts/gpu/aside.sh away > "$scratch/aside.log" || fail "aside.sh away: $(cat "$scratch/aside.log")"
FMSR_CUBECL_CACHE=$scratch/cubecl_cache.tar.gz scripts/gpu/pack.sh --cpu --bench ddpg_update --out "$pack" \
  > "$scratch/pack.log" 2>&1 || fail "pack.sh: $(tail -n 5 "$scratch/pack.log")"
scripts/gpu/aside.sh back > "$scratch/aside.log" || fail "aside.sh back: $(cat "$scratch/aside.log")"
grep -q "^set aside [0-9]* tracked files" "$pack/MANIFEST" || fail "the manifest does not say what was set aside: $(cat "$pack/MANIFEST")"
[ "$clean" = 0 ] || ! grep -q "with uncommitted changes" "$pack/MANIFEST" || fail "the files set aside counted as changes"
[ -f "$pack/cubecl_cache.tar.gz" ] || fail "the pack has no cubecl_cache.tar.gz"
[ -f "$pack/bin.tar.xz" ] || fail "the pack's binaries are not in one archive (in parts?): $(cat "$pack/MANIFEST")"
grep -q "^features none" "$pack/MANIFEST" || fail "the manifest: $(cat "$pack/MANIFEST")"

# A lease of 240 s: the bench checks its parity on the CPU too (FMSR_PARITY=1), then its
# 10 s end in its first benchmark; a device whose parity passed is kept though its timing
# ran out (the lease of 2026-11-26 lost vulkan:0 so). The runs get about 75 s, too few for
# an epoch of the paper's config here.
out=$scratch/out
FMSR_PARITY=1 FMSR_PACK=$pack FMSR_LEASE_DEVICES=cpu FMSR_LEASE_BENCH_SECONDS=10 FMSR_LEASE_PYTORCH=0 \
  FMSR_LEASE_CYCLE=0 FMSR_LEASE_SCALING=0 scripts/gpu/lease.sh "$out" 240 > "$scratch/lease.out" 2>&1 \
  || fail "lease.sh: $(tail -n 5 "$scratch/lease.out")"
log=$out/lease.log
grep -q "ddpg_update's timing did not finish on cpu (exit 124); its parity check passed" "$log" \
  || fail "the bench's limit: $(grep -A3 "ddpg_update on" "$log")"
grep -q "device for what follows: cpu" "$log" || fail "the device chosen"
grep -q "started block_dense_fmsr_is" "$log" || fail "Dense+FMSR+IS did not start"
grep -q "started block_dense " "$log" || fail "Dense did not start beside it"
for run in block_dense_fmsr_is block_dense; do
  grep -q "$run: trained 0 of 400 epochs" "$log" || fail "$run: finish.sh did not say what it reached"
  tar tzf "$out/runs.tar.gz" | grep -qx "$run.log" || fail "$run: its log is not in runs.tar.gz"
  [ -f "runs/gpu/$run.pid" ] && kill -0 "$(cat "runs/gpu/$run.pid")" 2> /dev/null && fail "$run still trains after finish"
done
tar xzf "$out/cubecl_cache.tar.gz" -O environment/fmsr-test-marker 2> /dev/null | grep -q "from an earlier lease" \
  || fail "the autotune results did not come back: $(tar tzf "$out/cubecl_cache.tar.gz" 2>&1)"

# FMSR_LEASE_FINISH=0: the runs go on when the command ends.
rm -rf runs/gpu "$scratch/out2"
FMSR_PACK=$pack FMSR_LEASE_DEVICES=none FMSR_LEASE_PYTORCH=0 FMSR_LEASE_CYCLE=0 FMSR_LEASE_SCALING=0 \
  FMSR_LEASE_FINISH=0 scripts/gpu/lease.sh "$scratch/out2" 40 > "$scratch/lease2.out" 2>&1 \
  || fail "lease.sh with FMSR_LEASE_FINISH=0: $(tail -n 5 "$scratch/lease2.out")"
grep -q "done: the runs train on" "$scratch/out2/lease.log" || fail "FMSR_LEASE_FINISH=0 did not end with the runs training"
for run in block_dense_fmsr_is block_dense; do
  kill -0 "$(cat "runs/gpu/$run.pid")" 2> /dev/null || fail "$run stopped with FMSR_LEASE_FINISH=0"
done

# cubecl_first_use.py on a small log: two matmul candidates, each slow on its first launch.
cat > "$scratch/cubecl.log" << 'EOF'
[START_KERNEL_COMPILATION]
name: cubek_matmul::batch::matmul_entry::MatmulEntry<
    burn_cubecl_fusion::Args,
>
| 3.5s       | MatmulEntry_0123abcd
[END_KERNEL_COMPILATION]
| 1.5s       | MatmulEntry_0123abcd
| 35µs       | MatmulEntry_0123abcd
[START_KERNEL_COMPILATION]
name: cubek_matmul::batch::matmul_entry::MatmulEntry<
[END_KERNEL_COMPILATION]
| 2.5s       | MatmulEntry_4567abcd
| 41.0ms     | ReduceKernel_89abcdef
EOF
summary=$(scripts/gpu/cubecl_first_use.py "$scratch/cubecl.log") || fail "cubecl_first_use.py: $summary"
echo "$summary" | grep -Eq '^MatmulEntry +2 +3 +4\.000 +2 +4\.000$' || fail "the matmul row: $summary"
echo "$summary" | grep -Eq '^ReduceKernel +0 +1 +0\.041 +0 +0\.000$' || fail "the reduce row: $summary"
echo "test_gpu_scripts: passed"
