#!/usr/bin/env bash
# Builds fmsr with burn's CUDA backend (cargo feature `cuda`: devices `cuda`,
# `cuda:N`) without the download that cubecl's LLVM bundler would make.
#
# burn's `cuda` needs cubecl-llvm, whose build script (tracel-llvm-bundler)
# downloads LLVM 23.1 from GitHub unless a matching one already sits at
# `$XDG_DATA_HOME/tracel/tracel-llvm-23.1.0-4` ({bin,include,lib,share} and a
# file `.tracel-llvm-installed`). PyPI's `mlc-llvm-static[all]` is such an
# LLVM (static, with NVPTX, headers and llvm-config): this script installs it
# into a venv in a cache outside the tree, links it where the bundler looks
# (under that cache, via XDG_DATA_HOME for the build only), and runs cargo.
#
#   scripts/build_cuda.sh                         # cargo build --release --features cuda
#   scripts/build_cuda.sh --bench ddpg_update     # more cargo build arguments
#   scripts/build_cuda.sh --features vulkan       # both GPU backends in one binary
#   FMSR_CUDA_CACHE=DIR scripts/build_cuda.sh     # another cache (default ~/.cache/fmsr/cuda-llvm)
#
# The binary links no CUDA library: cudarc opens libcuda when a CUDA device is
# first used, so it runs where NVIDIA's driver is, and lists no CUDA device
# elsewhere (`fmsr devices`). CUDARC_CUDA_VERSION (default 13000: CUDA 13,
# driver 580) picks the driver API cudarc binds. The kernels need libdevice
# at run time (`$CUDA_PATH/nvvm/libdevice` or /usr/local/cuda).
set -euo pipefail
cd "$(dirname "$0")/.."
data=$(scripts/cuda_llvm.sh)
XDG_DATA_HOME=$data CUDARC_CUDA_VERSION=${CUDARC_CUDA_VERSION:-13000} \
  cargo build --release --features cuda "$@"
