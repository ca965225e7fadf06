"""One joint DDPG update of 6 agents in PyTorch, the same computation as
fmsr-nn's DdpgLearner::learn (benches/ddpg_update.rs): per agent a critic
update (target actors of all agents, target critic, clipped target, MSE,
Adam) then an actor update (-Q + action_l2 * mean(mu^2), Adam), batch 256,
3 x 256 hidden layers, action dims [2, 3, 3, 3, 4, 5], global obs 153, goal 7,
actor inputs as in the bench: `FMSR_ACTOR_INPUTS` (comma-separated, set by
benches/ddpg_update.rs from the egg task's layout), else the dims below.
Prints `updates/s threads=T: X` on the CPU.

`update.py [iters] [--device cuda] [--batch 256,1024]`: on CUDA it times each
batch size (device work synchronised before the clock is read) and prints
`updates/s device=cuda batch=N: X`.
"""
import argparse
import os
import time

import torch
import torch.nn as nn

B = 256
HIDDEN = 256
LAYERS = 3
ACTION_DIMS = [2, 3, 3, 3, 4, 5]
LOCAL_DIMS = [60, 52, 52, 52, 58, 165]
NEIGHBOURS = [[], [5, 2], [1, 3], [2, 4], [3, 5], [4, 1]]
OBS, GOAL = 153, 7
A = sum(ACTION_DIMS)
GAMMA, L2 = 0.99, 1.0


def mlp(i, o, out_act=None):
    layers, prev = [], i
    for _ in range(LAYERS):
        layers += [nn.Linear(prev, HIDDEN), nn.ReLU()]
        prev = HIDDEN
    layers.append(nn.Linear(prev, o))
    if out_act:
        layers.append(out_act)
    return nn.Sequential(*layers)


def build(device, B):
    torch.manual_seed(0)
    in_dims = [LOCAL_DIMS[i] + GOAL + sum(ACTION_DIMS[j] for j in NEIGHBOURS[i]) for i in range(6)]
    if os.environ.get("FMSR_ACTOR_INPUTS"):
        in_dims = [int(d) for d in os.environ["FMSR_ACTOR_INPUTS"].split(",")]
        assert len(in_dims) == 6, "FMSR_ACTOR_INPUTS: six actor input sizes"
    cin = OBS + GOAL + A
    actors = [mlp(d, a, nn.Tanh()) for d, a in zip(in_dims, ACTION_DIMS)]
    critics = [mlp(cin, 1) for _ in range(6)]
    t_actors = [mlp(d, a, nn.Tanh()) for d, a in zip(in_dims, ACTION_DIMS)]
    t_critics = [mlp(cin, 1) for _ in range(6)]
    for net in actors + critics + t_actors + t_critics:
        net.to(device)
    for t, o in zip(t_actors + t_critics, actors + critics):
        t.load_state_dict(o.state_dict())
        for p in t.parameters():
            p.requires_grad_(False)
    a_opt = [torch.optim.Adam(a.parameters(), lr=1e-3, eps=1e-8) for a in actors]
    c_opt = [torch.optim.Adam(c.parameters(), lr=1e-3, eps=1e-8) for c in critics]
    rand = lambda *shape: torch.rand(*shape, device=device)
    og = rand(B, OBS + GOAL) * 2 - 1
    og_next = rand(B, OBS + GOAL) * 2 - 1
    acts = rand(B, A) * 2 - 1
    x = [rand(B, d) * 2 - 1 for d in in_dims]
    x_next = [rand(B, d) * 2 - 1 for d in in_dims]
    r = [rand(B, 1) - 2 for _ in range(6)]
    offs = [sum(ACTION_DIMS[:i]) for i in range(6)]

    def update():
        with torch.no_grad():
            a_next = torch.cat([t(xn) for t, xn in zip(t_actors, x_next)], 1)
            nxt = torch.cat([og_next, a_next], 1)
        now = torch.cat([og, acts], 1)
        for i in range(6):
            with torch.no_grad():
                y = (r[i] + GAMMA * t_critics[i](nxt)).clamp(-100.0, 0.0)
            loss = ((critics[i](now) - y) ** 2).mean()
            c_opt[i].zero_grad(set_to_none=True)
            loss.backward()
            c_opt[i].step()
        for i in range(6):
            mu = actors[i](x[i])
            joint = torch.cat([og, acts[:, : offs[i]], mu, acts[:, offs[i] + ACTION_DIMS[i]:]], 1)
            for p in critics[i].parameters():
                p.requires_grad_(False)
            loss = -critics[i](joint).mean() + L2 * (mu ** 2).mean()
            a_opt[i].zero_grad(set_to_none=True)
            loss.backward()
            a_opt[i].step()
            for p in critics[i].parameters():
                p.requires_grad_(True)

    return update


def rate(update, iters, sync):
    for _ in range(3):
        update()
    sync()
    start = time.perf_counter()
    for _ in range(iters):
        update()
    sync()
    return iters / (time.perf_counter() - start)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("iters", nargs="?", type=int, default=30)
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--batch", default=str(B))
    args = parser.parse_args()
    batches = [int(b) for b in args.batch.split(",")]
    if args.device == "cpu":
        update = build("cpu", batches[0])
        for threads in (1, 2):
            torch.set_num_threads(threads)
            print(f"updates/s threads={threads}: {rate(update, args.iters, lambda: None):.3f}", flush=True)
    else:
        for b in batches:
            update = build(args.device, b)
            r = rate(update, args.iters, torch.cuda.synchronize)
            print(f"updates/s device={args.device} batch={b}: {r:.3f} ({1e3 / r:.2f} ms)", flush=True)
    print(f"torch {torch.__version__}, batches {batches}, hidden {LAYERS}x{HIDDEN}, 6 agents", flush=True)


if __name__ == "__main__":
    main()
