"""Reference observations from gymnasium-robotics 1.4.2 (mujoco 3.17.0) for the
parity test `python_gymnasium_reference` in fmsr-envs/tests/mujoco_parity.rs.

    target/pyref-venv/bin/python scripts/pyref/gym_reference.py {block|egg} IN OUT

IN: first line the initial rotation of the object about Z (rad), then one line of
20 actions per step. The state is set as fmsr's task sets it: the model's initial
state (mj_resetData), the object at its model position rotated about Z, 10 settle
steps of 20 substeps at zero action; then gymnasium's own `step` for each action.
OUT: one line of the 153 observation values (touch as sensordata) per step,
starting with the one after settling.

gymnasium-robotics 1.4.2 needs gym_patch.py (beside this file) on mujoco 3.17.
"""

import math
import sys

import gymnasium as gym
import gymnasium_robotics
import mujoco
import numpy as np
from gym_patch import get_joint_qpos, set_joint_qpos

ENV_IDS = {
    "block": "HandManipulateBlockRotateZ_ContinuousTouchSensors-v1",
    "egg": "HandManipulateEggRotate_ContinuousTouchSensors-v1",
}


def main():
    obj, inp, out = sys.argv[1:4]
    lines = [l for l in open(inp).read().splitlines() if l.strip()]
    angle = float(lines[0])
    actions = [np.array([float(v) for v in l.split()], dtype=np.float32) for l in lines[1:]]
    gym.register_envs(gymnasium_robotics)
    env = gym.make(ENV_IDS[obj]).unwrapped
    env.reset(seed=0)
    m, d = env.model, env.data
    mujoco.mj_resetData(m, d)
    pos = get_joint_qpos(m, d, "object:joint")[:3]
    quat = [math.cos(angle / 2), 0.0, 0.0, math.sin(angle / 2)]
    set_joint_qpos(m, d, "object:joint", np.concatenate([pos, quat]))
    mujoco.mj_forward(m, d)
    for _ in range(10):
        env._set_action(np.zeros(20))
        mujoco.mj_step(m, d, nstep=env.n_substeps)
    rows = [env._get_obs()["observation"]]
    for a in actions:
        obs, _, _, _, _ = env.step(a)
        rows.append(obs["observation"])
    np.savetxt(out, np.array(rows), fmt="%.17g")


if __name__ == "__main__":
    main()
