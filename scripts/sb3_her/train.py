"""The peer: stable-baselines3's HER + DDPG on gymnasium-robotics'
HandManipulateBlockRotateZ_BooleanTouchSensors-v1 (MuJoCo 3.17), on HER
baselines' 1-CPU schedule, writing a metrics.csv to set beside fmsr's
single-agent reference (configs/lite/block_single_agent_sparse.toml; issue 11, item 6).

    scripts/sb3_her/setup_venv.sh
    target/sb3-venv/bin/python scripts/sb3_her/train.py --seed 0 --out runs/peer/sb3_her_s0

An epoch, as in HER baselines with one worker and in fmsr's lite configs: 50
cycles of 2 episodes (100 steps each, 10k env steps), each cycle followed by 40
gradient steps on batches of 256; then 10 deterministic test episodes, whose
success (the env's own 0.1 rad) is `success_rate`. The network (3 x 256), the
learning rates (1e-3), gamma 0.98, Gaussian action noise 0.2, HER's `future`
strategy with k = 4 (80 % relabelled), a 1M-transition buffer and observations
normalised and clipped to +-5 are HER baselines' settings. HER baselines moves
its target networks once per cycle (polyak 0.95 after the cycle's 40 batches);
SB3's DDPG moves them after every gradient step, so its tau is the per-step
rate of the same lag, 1 - 0.95^(1/40) = 0.00128 (with `--tau 0.05`, the
target networks move 40x faster than HER baselines').
Two of them SB3's DDPG has no switch for, so this peer runs without them:
HER baselines' 30 % uniformly random actions, and the actor's action-L2 penalty.

Columns of metrics.csv: epoch, env_steps, seconds (wall time since the start,
tests included), epoch_seconds, seconds_per_env_step (training only),
success_rate (test), train_success_rate (SB3's success over the last 100
training episodes). The file is rewritten atomically after every epoch.
"""

import argparse
import csv
import os
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "pyref"))
import gym_patch  # noqa: F401,E402  (gymnasium-robotics 1.4.2 on mujoco 3.17)

import gymnasium as gym  # noqa: E402
import gymnasium_robotics  # noqa: E402
import numpy as np  # noqa: E402
import torch  # noqa: E402
from stable_baselines3 import DDPG, HerReplayBuffer  # noqa: E402
from stable_baselines3.common.noise import NormalActionNoise  # noqa: E402
from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize  # noqa: E402

ENV_ID = "HandManipulateBlockRotateZ_BooleanTouchSensors-v1"
EPISODE_STEPS = 100
COLUMNS = ["epoch", "env_steps", "seconds", "epoch_seconds", "seconds_per_env_step", "success_rate", "train_success_rate"]


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", required=True, help="run directory (metrics.csv, model.zip)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--epochs", type=int, default=50)
    p.add_argument("--cycles", type=int, default=50)
    p.add_argument("--episodes-per-cycle", type=int, default=2)
    p.add_argument("--batches", type=int, default=40)
    p.add_argument("--batch-size", type=int, default=256)
    p.add_argument("--test-episodes", type=int, default=10)
    p.add_argument("--threads", type=int, default=1, help="torch threads (1, as fmsr's lite runs)")
    p.add_argument("--polyak", type=float, default=0.95, help="HER baselines' target lag per cycle")
    p.add_argument("--tau", type=float, default=None, help="SB3's per-step tau (default: the polyak's per-step rate)")
    args = p.parse_args()
    if not 0.0 < args.polyak < 1.0:
        p.error(f"--polyak must lie in (0, 1), got {args.polyak}")
    if args.tau is not None and not 0.0 < args.tau <= 1.0:
        p.error(f"--tau must lie in (0, 1], got {args.tau}")
    for name in ["epochs", "cycles", "episodes_per_cycle", "batches", "batch_size", "test_episodes", "threads"]:
        if getattr(args, name) < 1:
            p.error(f"--{name.replace('_', '-')} must be at least 1, got {getattr(args, name)}")
    return args


def per_step_tau(args):
    """SB3's tau: given, or the per-gradient-step rate of HER baselines' per-cycle polyak."""
    return args.tau if args.tau is not None else 1.0 - args.polyak ** (1.0 / args.batches)


def make_model(args, env):
    n_actions = env.action_space.shape[0]
    return DDPG(
        "MultiInputPolicy",
        env,
        learning_rate=1e-3,
        buffer_size=1_000_000,
        learning_starts=args.episodes_per_cycle * EPISODE_STEPS,
        batch_size=args.batch_size,
        tau=per_step_tau(args),
        gamma=0.98,
        train_freq=(args.episodes_per_cycle, "episode"),
        gradient_steps=args.batches,
        action_noise=NormalActionNoise(np.zeros(n_actions), 0.2 * np.ones(n_actions)),
        replay_buffer_class=HerReplayBuffer,
        replay_buffer_kwargs=dict(n_sampled_goal=4, goal_selection_strategy="future"),
        policy_kwargs=dict(net_arch=[256, 256, 256]),
        seed=args.seed,
        device="cpu",
        verbose=0,
    )


def test_success(model, vec_env, test_env, episodes, seed):
    """Fraction of deterministic test episodes that end within the env's threshold."""
    successes = 0
    for i in range(episodes):
        obs, _ = test_env.reset(seed=seed + i)
        info = {}
        for _ in range(EPISODE_STEPS):
            action, _ = model.predict(vec_env.normalize_obs(obs), deterministic=True)
            obs, _, terminated, truncated, info = test_env.step(action)
            if terminated or truncated:
                break
        successes += float(info.get("is_success", 0.0))
    return successes / episodes


def write_csv(path, rows):
    tmp = path + ".tmp"
    with open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS)
        w.writeheader()
        w.writerows(rows)
    os.replace(tmp, path)


def main():
    args = parse_args()
    os.makedirs(args.out, exist_ok=True)
    torch.set_num_threads(args.threads)
    gym.register_envs(gymnasium_robotics)
    env = VecNormalize(DummyVecEnv([lambda: gym.make(ENV_ID)]), norm_obs=True, norm_reward=False, clip_obs=5.0)
    env.seed(args.seed)
    test_env = gym.make(ENV_ID)
    model = make_model(args, env)
    steps_per_epoch = args.cycles * args.episodes_per_cycle * EPISODE_STEPS
    rows, start = [], time.time()
    for epoch in range(args.epochs):
        t0 = time.time()
        model.learn(total_timesteps=steps_per_epoch, reset_num_timesteps=False)
        trained = time.time() - t0
        env.training = False
        success = test_success(model, env, test_env, args.test_episodes, 10_000 * (args.seed + 1) + 100 * epoch)
        env.training = True
        buf = model.ep_success_buffer
        rows.append(
            dict(
                epoch=epoch,
                env_steps=model.num_timesteps,
                seconds=round(time.time() - start, 2),
                epoch_seconds=round(time.time() - t0, 2),
                seconds_per_env_step=trained / steps_per_epoch,
                success_rate=success,
                train_success_rate=float(np.mean(buf)) if len(buf) else 0.0,
            )
        )
        write_csv(os.path.join(args.out, "metrics.csv"), rows)
        print(f"epoch {epoch}: {model.num_timesteps} env steps, test success {success:.2f}, {rows[-1]['epoch_seconds']:.0f} s", flush=True)
    model.save(os.path.join(args.out, "model.zip"))


if __name__ == "__main__":
    main()
