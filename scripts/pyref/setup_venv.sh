#!/usr/bin/env bash
# Builds the Python reference venv (gymnasium-robotics 1.4.2 + mujoco 3.17.0) in
# <repo>/target/pyref-venv for the optional parity test
# `cargo test -p fmsr-envs --features mujoco --test envs_integration -- mujoco_parity::` (python_reference).
# Idempotent. Needs network access to PyPI the first time.
set -euo pipefail
cd "$(dirname "$0")/../.."
VENV="$PWD/target/pyref-venv"
if [ -x "$VENV/bin/python" ] && "$VENV/bin/python" -c "import gymnasium_robotics, mujoco; assert mujoco.__version__ == '3.17.0'" 2>/dev/null; then
  echo "reference venv ready: $VENV"
  exit 0
fi
python3 -m venv "$VENV"
"$VENV/bin/python" -m pip install --disable-pip-version-check -q "gymnasium-robotics==1.4.2" "mujoco==3.17.0"
"$VENV/bin/python" -c "import gymnasium_robotics, mujoco; print('gymnasium-robotics', gymnasium_robotics.__version__, 'mujoco', mujoco.__version__)"
echo "reference venv ready: $VENV"
