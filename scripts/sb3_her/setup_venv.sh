#!/usr/bin/env bash
# Builds the venv of the stable-baselines3 peer (issue 11, item 6) in
# <repo>/target/sb3-venv: stable-baselines3 (HER + DDPG), gymnasium-robotics 1.4.2,
# mujoco 3.17.0 and PyTorch. Idempotent; needs PyPI the first time (PyTorch is
# the large part: several GB with its CUDA libraries, unused here).
set -euo pipefail
cd "$(dirname "$0")/../.."
VENV="${FMSR_SB3_VENV:-$PWD/target/sb3-venv}"
check() {
  "$VENV/bin/python" -c "import stable_baselines3, gymnasium_robotics, mujoco, torch; assert mujoco.__version__ == '3.17.0'" 2>/dev/null
}
if [ -x "$VENV/bin/python" ] && check; then
  echo "sb3 venv ready: $VENV"
  exit 0
fi
python3 -m venv "$VENV"
"$VENV/bin/python" -m pip install --disable-pip-version-check -q \
  "stable-baselines3==2.9.2" "gymnasium-robotics==1.4.2" "mujoco==3.17.0" torch
"$VENV/bin/python" -c "import stable_baselines3 as sb3, gymnasium_robotics as gr, mujoco, torch; print('stable-baselines3', sb3.__version__, 'gymnasium-robotics', gr.__version__, 'mujoco', mujoco.__version__, 'torch', torch.__version__)"
echo "sb3 venv ready: $VENV"
