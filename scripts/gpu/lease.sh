#!/usr/bin/env bash
# A short GPU lease in one command, on the GPU machine (issue 40, items 2a and
# 2b), for a pack made with
#
#   scripts/gpu/pack.sh --bench ddpg_update [--bench paper_epoch] [--features vulkan,cuda]
#
# (a pack in parts, .gpu-N beside .gpu: first a call of its own per .gpu-N
# that carries it and runs `true`, on the same machine), and then, there, in
# the repository's root:
#
#   scripts/gpu/lease.sh OUT_DIR [SECONDS]     # SECONDS: this command's wall time (default 540)
#
# 1. the machine: GPU, driver, cores, the pack's commit, `fmsr devices`;
# 2. benches/ddpg_update.rs (criterion; batch 256 and 1024, action selection)
#    on the first of vulkan:0, cuda:0, vulkan, wgpu:0, wgpu that runs it and computes the CPU's
#    updates (its parity check): the device of what follows, else cpu
#    (FMSR_LEASE_DEVICES: other candidates, in order);
# 3. the same update in PyTorch on CUDA (scripts/pytorch_reference);
# 4. the block's Dense+FMSR+IS at the paper's config alone until its first
#    epoch is done (a paper epoch on all cores and the GPU: metrics.csv's
#    seconds, env steps/s and updates/s), then Dense beside it
#    (scripts/gpu/start.sh), both until 150 s before the end; then
#    scripts/gpu/finish.sh: evaluation, rendering, report, policies.
#
# Every step has its own time limit and a failing step does not stop the
# next: what comes back says which failed. OUT_DIR gets lease.log (all of the
# above), runs.tar.gz and one policy file per run.
set -uo pipefail
cd "$(dirname "$0")/../.."
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
for candidate in ${FMSR_LEASE_DEVICES:-vulkan:0 cuda:0 vulkan wgpu:0 wgpu}; do
  printf '%s\n' "${devices[@]}" | grep -qx "$candidate" || continue
  step "ddpg_update on $candidate (criterion: time [low median high])"
  if FMSR_DEVICE=$candidate timeout 150 "$bin/ddpg_update" --bench --warm-up-time 1 --measurement-time 3 \
    | tee "$out/ddpg_update.txt" && grep -q "equal within tolerance" "$out/ddpg_update.txt"; then
    device=$candidate
    break
  fi
  echo "ddpg_update failed or differs from the CPU on $candidate"
done
rm -f "$out/ddpg_update.txt"
echo "device for what follows: $device"
step "the same update in PyTorch on CUDA"
timeout 90 scripts/pytorch_reference/run.sh 50 --device cuda --batch 256,1024 || echo "PyTorch reference failed (exit $?)"

if [ -x "$bin/paper_epoch" ]; then
  step "one cycle of a paper epoch on $device: collecting against updating"
  FMSR_DEVICE=$device FMSR_EPOCH_CYCLES=1 FMSR_EPOCH_CONFIG=configs/block_dense_fmsr_is.toml \
    timeout 150 "$bin/paper_epoch" || echo "paper_epoch failed (exit $?)"
fi

runs=(block_dense_fmsr_is block_dense)
step "a paper epoch: ${runs[0]} alone on $device and $(nproc) cores"
FMSR_GPU_DEVICE=$device scripts/gpu/start.sh "configs/${runs[0]}.toml" || echo "start ${runs[0]} failed"
first=runs/gpu/${runs[0]}/metrics.csv
while [ "$(wc -l 2>/dev/null < "$first" || echo 0)" -lt 2 ] && [ "$(left)" -gt 240 ]; do sleep 2; done
cut -d, -f1-9 "$first" 2>/dev/null || tail -n 5 "runs/gpu/${runs[0]}.log"
step "${runs[1]} beside it, both until $((budget - 150)) s"
FMSR_GPU_DEVICE=$device scripts/gpu/start.sh "configs/${runs[1]}.toml" || echo "start ${runs[1]} failed"
while [ "$(left)" -gt 150 ]; do
  sleep 30
  scripts/gpu/status.sh "${runs[@]}" | grep '^=='
done
step "status"
scripts/gpu/status.sh "${runs[@]}"
step finish
timeout $(($(left) - 10)) scripts/gpu/finish.sh "$out" "${runs[@]}" || echo "finish failed (exit $?)"
step "done"
