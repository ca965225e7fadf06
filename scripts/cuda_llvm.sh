#!/usr/bin/env bash
# The LLVM that burn's `cuda` feature builds against, without its download:
# installs PyPI's static LLVM 23.1 (`mlc-llvm-static[all]`, about 400 MB) into
# a venv in a cache outside the tree (FMSR_CUDA_CACHE, default
# ~/.cache/fmsr/cuda-llvm) once, links it where tracel-llvm-bundler's build
# script looks for an installed LLVM (`$XDG_DATA_HOME/tracel/
# tracel-llvm-23.1.0-4` with a file `.tracel-llvm-installed`), and prints the
# XDG_DATA_HOME to build with. Used by scripts/build_cuda.sh and
# scripts/gpu/pack.sh.
set -euo pipefail
cache=${FMSR_CUDA_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/fmsr/cuda-llvm}
wheel="mlc-llvm-static[all]==23.1.1.post0"
venv=$cache/venv
mkdir -p "$cache"
if ! "$venv/bin/python" -c 'import mlc_llvm_static' 2>/dev/null; then
  python3 -m venv "$venv" >&2
  "$venv/bin/pip" install --quiet --upgrade pip >&2
  "$venv/bin/pip" install --quiet "$wheel" >&2
fi
prefix=$("$venv/bin/python" -m mlc_llvm_static.config --prefix)
data=$cache/xdg
llvm=$data/tracel/tracel-llvm-23.1.0-4
if [ ! -f "$llvm/.tracel-llvm-installed" ]; then
  mkdir -p "$llvm"
  for d in bin include lib share; do
    if [ -e "$prefix/$d" ]; then ln -sfn "$prefix/$d" "$llvm/$d"; else mkdir -p "$llvm/$d"; fi
  done
  echo "$wheel from PyPI, linked by scripts/cuda_llvm.sh" > "$llvm/.tracel-llvm-installed"
fi
echo "LLVM $("$llvm/bin/llvm-config" --version) at $prefix" >&2
echo "$data"
