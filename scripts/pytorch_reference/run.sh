#!/usr/bin/env bash
# Times one joint DDPG update of the 6 Shadow Hand agents in PyTorch (CPU),
# with the sizes of benches/ddpg_update.rs. Creates its own venv under
# target/pytorch_reference_venv and pip-installs the PyTorch CPU wheel there.
# Prints `updates/s threads=T: X` lines that the bench parses.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
venv="${FMSR_PYTORCH_VENV:-$root/target/pytorch_reference_venv}"
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
    "$venv/bin/pip" install --quiet --upgrade pip
    "$venv/bin/pip" install --quiet torch --index-url https://download.pytorch.org/whl/cpu \
        || "$venv/bin/pip" install --quiet torch
fi
exec "$venv/bin/python" "$here/update.py" "$@"
