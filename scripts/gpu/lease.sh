#!/usr/bin/env bash
# A short GPU lease in one command, on the GPU machine (issue 40, items 2a and
# 2b), for a pack made with
#
#   scripts/gpu/pack.sh --bench ddpg_update [--features vulkan,cuda]
#
# (a pack in parts, .gpu-N beside .gpu: first a call of its own per .gpu-N
# that carries it and runs `true`, on the same machine), and then, there, in
# the repository's root:
#
#   scripts/gpu/lease.sh OUT_DIR [SECONDS]     # SECONDS: this command's wall time (default 540)
#
# 1. the machine: GPU, driver, cores, the pack's commit, `fmsr devices`;
# 2. benches/ddpg_update.rs (criterion; batch 256 and 1024, action selection)
#    on the first of vulkan:0, cuda:0, wgpu:0 that runs it and computes the CPU's
#    updates (its parity check): the device of what follows, else cpu
#    (FMSR_LEASE_DEVICES: other candidates, in order);
# 3. the same update in PyTorch on CUDA (scripts/pytorch_reference);
# 4. two epochs of one cycle each of the block's Dense+FMSR+IS on that device
#    (seconds collecting against updating);
# 5. collecting on 1, 2, 4 and 8 stepping threads (FMSR_LEASE_SCALING=0: not);
# 6. the block's Dense+FMSR+IS at the paper's config alone until its first
#    epoch is done (a paper epoch on all cores and the GPU: metrics.csv's
#    seconds, env steps/s and updates/s), then Dense beside it
#    (scripts/gpu/start.sh), both until 150 s before the end; then
#    scripts/gpu/finish.sh: evaluation, rendering, report, policies.
#
# FMSR_PACK names another pack (say a `cuda` one beside the `vulkan` one, in a
# second call on the same machine); FMSR_LEASE_RUNS=none leaves out step 6,
# FMSR_LEASE_PYTORCH=0 step 3 (measured already in this lease);
# FMSR_LEASE_CYCLE_SECONDS limits step 4 (default 150), FMSR_LEASE_CUBECL_LOG=1
# brings back its cubecl log, FMSR_LEASE_CYCLE=0 leaves it out;
# FMSR_LEASE_BENCH_SECONDS limits each try of step 2 (default 150);
# FMSR_LEASE_ALONE_EPOCHS: the epochs the first run trains alone in step 6
# (default 1: epoch 0 holds the first use of every shape, epoch 1 is warm);
# FMSR_LEASE_FINISH=0 leaves the runs of step 6 training at the end (until
# the machine goes back), for a later call on the same machine to run
# `scripts/gpu/finish.sh OUT_DIR block_dense_fmsr_is block_dense`.
#
# Every step has its own time limit and a failing step does not stop the
# next: what comes back says which failed. OUT_DIR gets lease.log (all of the
# above), runs.tar.gz, one policy file per run, and cubecl_cache.tar.gz:
# cubecl's persistent autotune results (target/environment), which the next
# pack carries when copied to ~/.cache/fmsr/ (scripts/gpu/pack.sh), so that
# the next lease's first use of each shape skips the candidates' trials.
set -uo pipefail
cd "$(dirname "$0")/../.." || exit
if [ $# -lt 1 ]; then
  echo "usage: $0 OUT_DIR [SECONDS]" >&2
  exit 2
fi
out=$1
budget=${2:-540}
start=$(date +%s)
left() { echo $((budget - ($(date +%s) - start))); }
mkdir -p "$out"
exec > >(tee -a "$out/lease.log") 2>&1
step() { echo; echo "== [$(($(date +%s) - start)) s] $*"; }
# On every exit: cubecl's autotune results of this machine, for the next pack.
save_cubecl_cache() {
  [ -d target/environment ] && tar czf "$out/cubecl_cache.tar.gz" -C target environment
}
trap save_cubecl_cache EXIT

step machine
# shellcheck source=scripts/gpu/env.sh
. scripts/gpu/env.sh
bin=${FMSR_PACK:-.gpu}/bin
cat "${FMSR_PACK:-.gpu}/MANIFEST"
nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.sm,clocks.max.sm --format=csv
echo "cores: $(nproc)"
step "fmsr devices"
mapfile -t devices < <("$FMSR" devices)
printf '%s\n' "${devices[@]}"
if ! printf '%s\n' "${devices[@]}" | grep -q vulkan; then
  echo "no Vulkan adapter; the loader says:"
  VK_LOADER_DEBUG=error,warn "$FMSR" devices 2>&1 | sort -u | head -n 10
fi

device=cpu
# Not `vulkan` or `wgpu` too: they name the default adapter, on a one-GPU
# machine the same GPU, and a retry there cost the lease of 2026-11-26 110 s.
for candidate in ${FMSR_LEASE_DEVICES:-vulkan:0 cuda:0 wgpu:0}; do
  printf '%s\n' "${devices[@]}" | grep -qx "$candidate" || continue
  if [ ! -x "$bin/ddpg_update" ]; then
    echo "no ddpg_update in the pack: $candidate, listed, without the parity check"
    device=$candidate
    break
  fi
  step "ddpg_update on $candidate (criterion: time [low median high])"
  FMSR_DEVICE=$candidate timeout "${FMSR_LEASE_BENCH_SECONDS:-150}" "$bin/ddpg_update" --bench \
    --warm-up-time 1 --measurement-time 3 | tee "$out/ddpg_update.txt"
  bench=$?
  # The parity check comes first: a device that passed it trains what
  # follows even where the timing did not finish in its limit.
  if grep -q "equal within tolerance" "$out/ddpg_update.txt"; then
    [ "$bench" -ne 0 ] && echo "ddpg_update's timing did not finish on $candidate (exit $bench); its parity check passed"
    device=$candidate
    break
  fi
  echo "ddpg_update failed or differs from the CPU on $candidate (exit $bench)"
done
rm -f "$out/ddpg_update.txt"
echo "device for what follows: $device"
if [ "${FMSR_LEASE_PYTORCH:-1}" != 0 ]; then
  step "the same update in PyTorch on CUDA"
  timeout 90 scripts/pytorch_reference/run.sh 50 --device cuda --batch 256,1024 || echo "PyTorch reference failed (exit $?)"
fi

# The paper's config with 1 cycle (800 env steps, 25 joint updates) and no
# evaluation episodes (steps 4 and 5).
one_cycle() {  # ARGS: more sed expressions
  sed -e 's/^cycles = .*/cycles = 1/' -e 's/^eval_episodes = .*/eval_episodes = 0/' "$@" configs/block_dense_fmsr_is.toml
}
if [ "${FMSR_LEASE_CYCLE:-1}" != 0 ]; then
  step "two one-cycle epochs of the block's Dense+FMSR+IS on $device and $(nproc) cores (epoch 0 with first-use compilation and tuning)"
  # metrics.csv's env steps/s while collecting and updates/s, epoch 1 warm.
  # x25 cycles is a paper epoch without its evaluation.
  cycle=runs/gpu/cycle_${device//:/_}
  one_cycle > "$out/cycle.toml"
  rm -rf "$cycle"
  # FMSR_LEASE_CUBECL_LOG=1: cubecl's log of these epochs (compilation, tuning,
  # profiling) comes back as cubecl.log.xz, to see where a first use goes, with
  # its summary by scripts/gpu/cubecl_first_use.py.
  log=()
  [ "${FMSR_LEASE_CUBECL_LOG:-0}" = 1 ] && log=(env "CUBECL_DEBUG_LOG=$out/cubecl.log")
  timeout "${FMSR_LEASE_CYCLE_SECONDS:-150}" "${log[@]}" "$FMSR" train --config "$out/cycle.toml" --device "$device" \
    --epochs 2 --out "$cycle" --quiet || echo "one-cycle epochs failed (exit $?)"
  if [ -f "$out/cubecl.log" ]; then
    # Per kernel family: compiled, launches, their time, the slow (first) launches.
    python3 scripts/gpu/cubecl_first_use.py "$out/cubecl.log" | tee "$out/cubecl_first_use.txt"
    xz -T0 "$out/cubecl.log"
  fi
  cut -d, -f1,5-9 "$cycle/metrics.csv" 2>/dev/null
  rm -f "$out/cycle.toml"
fi

if [ "${FMSR_LEASE_SCALING:-1}" != 0 ]; then
  step "collecting against stepping threads: one cycle of 8 envs (800 env steps), networks on the CPU"
  # Collecting took 35 s of a 48 s paper epoch on 16 cores and the GPU (second
  # lease of 2026-11-26): the trainer stepped its 8 envs on one thread until
  # e9d1dd2. How far does collecting scale with stepping threads there?
  for threads in 1 2 4 8; do
    one_cycle -e 's/^batches = .*/batches = 1/' -e "s/^\[trainer\]\$/[trainer]\nthreads = $threads/" > "$out/threads.toml"
    rm -rf "runs/gpu/threads_$threads"
    if timeout 60 "$FMSR" train --config "$out/threads.toml" --device cpu --epochs 1 --out "runs/gpu/threads_$threads" --quiet; then
      echo "threads $threads: $(cut -d, -f7 "runs/gpu/threads_$threads/metrics.csv" | tail -n 1) env steps/s collecting"
    else
      echo "threads $threads: failed (exit $?)"
    fi
  done
  rm -f "$out/threads.toml"
fi

if [ "${FMSR_LEASE_RUNS:-}" = none ]; then
  step "done"
  exit 0
fi
runs=(block_dense_fmsr_is block_dense)
alone=${FMSR_LEASE_ALONE_EPOCHS:-1}
finish=${FMSR_LEASE_FINISH:-1}
# The time kept at the end: finish.sh's evaluations, or a status alone.
tail_s=150
[ "$finish" = 0 ] && tail_s=15
step "a paper epoch: ${runs[0]} alone on $device and $(nproc) cores for $alone epoch(s)"
FMSR_GPU_DEVICE=$device scripts/gpu/start.sh "configs/${runs[0]}.toml" || echo "start ${runs[0]} failed"
first=runs/gpu/${runs[0]}/metrics.csv
while [ "$(wc -l 2>/dev/null < "$first" || echo 0)" -le "$alone" ] && [ "$(left)" -gt $((tail_s + 90)) ]; do sleep 2; done
cut -d, -f1-9 "$first" 2>/dev/null || tail -n 5 "runs/gpu/${runs[0]}.log"
step "${runs[1]} beside it, both until $((budget - tail_s)) s"
FMSR_GPU_DEVICE=$device scripts/gpu/start.sh "configs/${runs[1]}.toml" || echo "start ${runs[1]} failed"
while [ "$(left)" -gt "$tail_s" ]; do
  until_tail=$(($(left) - tail_s))
  sleep $((until_tail > 30 ? 30 : (until_tail > 0 ? until_tail : 1)))
  scripts/gpu/status.sh "${runs[@]}" | grep '^=='
done
step "status"
scripts/gpu/status.sh "${runs[@]}"
if [ "$finish" = 0 ]; then
  step "done: the runs train on; finish them with scripts/gpu/finish.sh OUT_DIR ${runs[*]}"
  exit 0
fi
step finish
timeout $(($(left) - 10)) scripts/gpu/finish.sh "$out" "${runs[@]}" || echo "finish failed (exit $?)"
step "done"
