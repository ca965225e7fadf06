#!/usr/bin/env bash
# Runs the GPU code path's test (tests/gpu.rs, feature `wgpu`): the device found by
# name, joint MADDPG updates equal to burn's flex CPU backend's, and Dense+FMSR+IS
# learning TeamReach on the device. CI only type-checks it (.ci/run: the wgpu build
# takes over 20 minutes on 2 cores); run this when the GPU path changes (fmsr-nn's
# device, networks, stacking or mixing) and say so in the commit.
#
#   scripts/test_gpu.sh                             # Mesa's lavapipe, device wgpu:cpu (installs it)
#   FMSR_GPU_TEST_DEVICE=wgpu:0 scripts/test_gpu.sh # a real GPU with its Vulkan driver
#
# On lavapipe the first kernels take minutes to compile.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ -z "${FMSR_GPU_TEST_DEVICE:-}" ]; then
  scripts/setup_lavapipe.sh
fi
XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-$(mktemp -d)}" cargo test --features wgpu --test gpu -- --nocapture
