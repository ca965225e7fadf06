#!/usr/bin/env bash
# Times one joint DDPG update of the 6 Shadow Hand agents in PyTorch, with the
# sizes of benches/ddpg_update.rs. On the CPU it creates its own venv under
# target/pytorch_reference_venv and pip-installs the PyTorch CPU wheel there,
# and prints `updates/s threads=T: X` lines that the bench parses. With
# `--device cuda` it uses the machine's python3 and its CUDA build of PyTorch
# (an offline GPU machine has no index to install from):
#
#   scripts/pytorch_reference/run.sh 50 --device cuda --batch 256,1024
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
if [[ " $* " == *" --device cuda"* ]]; then
    exec python3 "$here/update.py" "$@"
fi
venv="${FMSR_PYTORCH_VENV:-$root/target/pytorch_reference_venv}"
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
    "$venv/bin/pip" install --quiet --upgrade pip
    "$venv/bin/pip" install --quiet torch --index-url https://download.pytorch.org/whl/cpu \
        || "$venv/bin/pip" install --quiet torch
fi
exec "$venv/bin/python" "$here/update.py" "$@"
