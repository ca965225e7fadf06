#!/usr/bin/env bash
# Installs what the `mpi` feature needs on Debian/Ubuntu: Open MPI (library,
# headers and mpirun) and libclang for the bindings of the `mpi` crate.
#
#   scripts/setup_mpi.sh
#   cargo build --release --features mpi
#   mpirun -np 4 target/release/fmsr train --config configs/block_dense_fmsr_is.toml
#
# Idempotent: installs nothing when mpirun, mpicc and libclang are present.
# Needs root (or sudo) for apt-get.
set -euo pipefail
have_clang() { ls /usr/lib/llvm-*/lib/libclang*.so* >/dev/null 2>&1 || ls /usr/lib/*/libclang*.so* >/dev/null 2>&1; }
if command -v mpirun >/dev/null && command -v mpicc >/dev/null && have_clang; then
  echo "MPI already installed: $(mpirun --version | head -n 1)"
  exit 0
fi
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
$SUDO apt-get update
$SUDO apt-get install -y --no-install-recommends libopenmpi-dev openmpi-bin libclang-dev
echo "installed: $(mpirun --version | head -n 1)"
