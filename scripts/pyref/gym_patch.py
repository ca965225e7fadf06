"""gymnasium-robotics 1.4.2 on mujoco 3.17.0: the library's joint helpers compare
`model.jnt_type[i]` with `mujoco.mjtJoint` members, which fails with mujoco 3.17's
bindings; importing this module replaces them by equivalents that use
`int(model.jnt_type[i])`. Used by gym_reference.py and ../sb3_her/train.py.
"""

import mujoco
from gymnasium_robotics.utils import mujoco_utils

_NQ = {int(mujoco.mjtJoint.mjJNT_FREE): 7, int(mujoco.mjtJoint.mjJNT_BALL): 4}
_NV = {int(mujoco.mjtJoint.mjJNT_FREE): 6, int(mujoco.mjtJoint.mjJNT_BALL): 3}


def _joint(model, name, sizes, adr):
    j = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
    assert j != -1, name
    start = int(adr[j])
    return start, start + sizes.get(int(model.jnt_type[j]), 1)


def get_joint_qpos(model, data, name):
    a, b = _joint(model, name, _NQ, model.jnt_qposadr)
    return data.qpos[a:b].copy()


def get_joint_qvel(model, data, name):
    a, b = _joint(model, name, _NV, model.jnt_dofadr)
    return data.qvel[a:b].copy()


def set_joint_qpos(model, data, name, value):
    a, b = _joint(model, name, _NQ, model.jnt_qposadr)
    data.qpos[a:b] = value


def set_joint_qvel(model, data, name, value):
    a, b = _joint(model, name, _NV, model.jnt_dofadr)
    data.qvel[a:b] = value


for _f in (get_joint_qpos, get_joint_qvel, set_joint_qpos, set_joint_qvel):
    setattr(mujoco_utils, _f.__name__, _f)
