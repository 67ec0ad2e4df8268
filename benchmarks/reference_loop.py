"""The ``reference`` setup of ``train_throughput.py``: the trainer's arithmetic in plain torch.

A CleanRL-style loop with no TensorDict, TorchRL or Hydra on its path (the config is
composed with the project's loader, then only read): per group the actor (Gaussian mean
MLP with a state-free log std, or logits), worker and manager critics, each the MLP
``rlhc.modules.mlp.group_mlp`` builds from ``cfg.model``; the game's batched numpy step;
``algo.normalize_observations``; GAE on ``max(V_w, V_m)`` (PPO: ``V_w``) bootstrapping
truncations and cuts; ``algo.epochs`` of whole shuffled minibatches of the clipped PPO
loss, both critics' squared errors and the entropy bonus; one fused Adam with the
gradient-norm clip. Left out: diagnostics, logging, annealing and checkpoints.

Its honesty checks, printed: its minibatch step against a bare ``nn.Linear`` loop of its
networks (forward, backward, clip, Adam) on the same shapes, interleaved in this process;
its FLOP per frame, counted on every ``nn.Linear`` during the first update, against
:func:`rlhc.building.flops.training_flops` (which also counts each epoch's remainder
under a minibatch, trained by neither).
"""

from __future__ import annotations

import copy
import itertools
import math
import statistics
import time
from typing import Any

import torch
from torch import Tensor, nn
from torch.nn import functional as F

from rlhc.envs.base import ContinuousAction

#: The most a minibatch step may exceed the bare loop's, and the counted FLOP the trainer's.
STEP_TOLERANCE, FLOP_TOLERANCE = 0.10, 0.05
#: Per group: obs, manager obs, action, log-prob, advantage, value target.
Columns = dict[str, list[Tensor]]


def mlp(n_in: int, n_out: int, model: Any) -> nn.Sequential:
    """``model.num_layers`` activated hidden layers, then a linear head (``group_mlp``'s)."""
    sizes = [n_in] + [model.hidden_size] * model.num_layers
    hidden = [m for a, b in itertools.pairwise(sizes) for m in (nn.Linear(a, b), model.activation_class())]  # fmt: skip
    return nn.Sequential(*hidden, nn.Linear(sizes[-1], n_out))


class GroupNets(nn.Module):
    """One group's actor, worker critic and (unless PPO) manager critic."""

    def __init__(self, spec: Any, cfg: Any, manager: bool) -> None:
        super().__init__()
        self.continuous = isinstance(spec.action, ContinuousAction)
        self.actor = mlp(spec.observation_size, spec.action.size if self.continuous else spec.action.n, cfg.model)  # fmt: skip
        if self.continuous:  # rlhc.modules.actors, action_dist=gaussian
            self.divisor = cfg.model.pre_clip_range
            with torch.no_grad():
                for parameter in self.actor[-1].parameters():
                    parameter.mul_(cfg.model.head_init_scale)
            self.log_std = nn.Parameter(torch.full((spec.action.size,), math.log(cfg.model.initial_action_scale)))  # fmt: skip
        self.worker = mlp(spec.observation_size, 1, cfg.model)
        self.manager = mlp(spec.manager_observation_size, 1, cfg.model) if manager else None

    def value(self, obs: Tensor, manager_obs: Tensor) -> Tensor:
        """The fused value ``max(V_w, V_m)`` (PPO: ``V_w``), ``[..., n_g, 1]``."""
        worker = self.worker(obs)
        return worker if self.manager is None else torch.maximum(worker, self.manager(manager_obs))

    def policy(self, obs: Tensor, action: Tensor | None) -> tuple[Tensor, Tensor, Tensor]:
        """``(action, log-probability [..., 1], mean entropy)``; an action drawn when ``None``."""
        out, half_log_2pi = self.actor(obs), 0.5 * math.log(2 * math.pi)
        if self.continuous:  # N(loc, scale) in action units, unsquashed: the game clips
            loc, log_scale = out / self.divisor, self.log_std - math.log(self.divisor)
            if action is None:
                action = loc + log_scale.exp() * torch.randn_like(loc)
            z = (action - loc) / log_scale.exp()
            log_prob = -(0.5 * z.square() + (log_scale + half_log_2pi)).sum(-1, keepdim=True)
            return action, log_prob, (log_scale + 0.5 + half_log_2pi).sum()
        log_p = out.log_softmax(-1)
        if action is None:
            action = torch.multinomial(log_p.exp().flatten(0, -2), 1).view(*log_p.shape[:-1], 1)
        # The mean over rows of -sum_a p log p is -n_actions * mean(p log p).
        return action, log_p.gather(-1, action), -log_p.shape[-1] * (log_p.exp() * log_p).mean()


class RunningNorm:
    """Running mean/std per agent slot (``SafeVecNorm``'s moments, decay per world-decision)."""

    def __init__(self, decay: float) -> None:
        self.decay, self.moments, self.seen = decay, {}, {}  # type: ignore[var-annotated]

    def __call__(self, key: str, x: Tensor) -> Tensor:
        self.seen[key] = self.seen.get(key, 0) + len(x)
        mean, square = self.moments.setdefault(key, [x.mean(0), (x * x).mean(0)])
        weight = len(x) / self.seen[key] if self.decay == 1.0 else 1 - self.decay ** len(x)
        mean.lerp_(x.mean(0), weight), square.lerp_((x * x).mean(0), weight)
        return (x - mean) / ((square - mean * mean).clamp_min(0).sqrt() + 1e-6)


class Reference:
    """The loop: :meth:`collect` (then :meth:`estimate`), :meth:`update` (epochs of :meth:`step`)."""

    def __init__(self, cfg: Any) -> None:
        from rlhc.building.builders import Layout
        from rlhc.envs import make_game

        critic, model = cfg.critic, cfg.model
        unsupported = [name for name, differs in (
            ("critic.fusion", critic.fusion not in ("max", "local")),
            ("critic.manager_interval", critic.manager_interval != 1),
            ("critic.manager_view", not critic.manager_view),
            ("model.action_dist", model.action_dist != "gaussian"),
            ("model.actor_view", model.actor_view != "worker"),
            ("league", cfg.league.active), ("shaping", cfg.shaping.scale > 0),
            ("device", cfg.device != "cpu"),
        ) if differs]  # fmt: skip
        if unsupported:
            raise ValueError(f"the reference loop does not implement these settings: {unsupported}")
        self.cfg, self.layout = cfg, Layout.from_config(cfg)
        torch.manual_seed(cfg.seed)
        self.game = make_game(cfg.env.name, num_envs=self.layout.num_envs, seed=cfg.seed, **cfg.env.game_options())  # fmt: skip
        manager = critic.fusion == "max" or critic.manager_diagnostics
        self.nets = {spec.name: GroupNets(spec, cfg, manager) for spec in self.game.groups}
        self.parameters = [p for net in self.nets.values() for p in net.parameters()]
        self.optimizer = torch.optim.Adam(self.parameters, lr=cfg.algo.lr, fused=True)
        self.norm = RunningNorm(cfg.algo.observation_decay) if cfg.algo.normalize_observations else None  # fmt: skip
        self.game.reset()
        self.obs = self.observe()

    def observe(self) -> dict[str, tuple[Tensor, Tensor]]:
        obs = {g: (torch.from_numpy(o.observation), torch.from_numpy(o.manager_observation))
               for g, o in self.game.observe().items()}  # fmt: skip
        norm = self.norm
        return obs if norm is None else {g: (norm(f"{g}/w", w), norm(f"{g}/m", m)) for g, (w, m) in obs.items()}  # fmt: skip

    def collect(self) -> Columns:
        """``steps_per_world`` decisions of every world, then :meth:`estimate`."""
        steps, worlds = self.layout.steps_per_world, self.layout.num_envs
        data: dict[str, list[list[Tensor]]] = {g: [[] for _ in range(5)] for g in self.nets}
        terminated, ends, finals = torch.zeros(steps, worlds), torch.zeros(steps, worlds), []
        for t in range(steps):
            actions = {}
            with torch.no_grad():
                for g, net in self.nets.items():
                    action, log_prob, _ = net.policy(self.obs[g][0], None)
                    actions[g] = (action if net.continuous else action.squeeze(-1)).numpy()
                    for column, x in zip(data[g], (*self.obs[g], action, log_prob), strict=False):
                        column.append(x)
            outcome = self.game.step(actions)
            for g in self.nets:
                data[g][4].append(torch.from_numpy(outcome.rewards[g]).unsqueeze(-1))
            done = outcome.terminated | outcome.truncated
            terminated[t], ends[t] = torch.from_numpy(outcome.terminated), torch.from_numpy(done)
            self.obs = self.observe()
            if outcome.truncated.any():  # bootstrapped from the observation before the reset
                finals.append((t, torch.from_numpy(outcome.truncated), self.obs))
            if done.any():
                self.game.reset(done)
                self.obs = self.observe()
        ends[self.layout.time_horizon - 1 :: self.layout.time_horizon] = 1.0  # trajectory cuts
        stacked = {g: [torch.stack(column) for column in columns] for g, columns in data.items()}
        return self.estimate(stacked, terminated[..., None, None], ends[..., None, None], finals)

    @torch.no_grad()
    def estimate(self, data: Columns, terminated: Tensor, ends: Tensor, finals: list[Any]) -> Columns:  # fmt: skip
        """GAE on the fused value; per group the columns, flattened over worlds and steps."""
        gamma, lmbda = self.cfg.algo.gamma, self.cfg.algo.lmbda
        batch = {}
        for g, net in self.nets.items():
            obs, manager_obs, action, log_prob, reward = data[g]
            value = net.value(torch.cat([obs, self.obs[g][0][None]]), torch.cat([manager_obs, self.obs[g][1][None]]))  # fmt: skip
            next_value = value[1:].clone()
            for t, truncated, final in finals:
                next_value[t, truncated] = net.value(final[g][0][truncated], final[g][1][truncated])
            advantage, last = torch.zeros_like(reward), torch.zeros_like(reward[0])
            for t in reversed(range(len(reward))):
                delta = reward[t] + gamma * next_value[t] * (1 - terminated[t]) - value[t]
                advantage[t] = last = delta + gamma * lmbda * (1 - ends[t]) * last
            columns = (obs, manager_obs, action, log_prob, advantage, advantage + value[:-1])
            batch[g] = [column.flatten(0, 1) for column in columns]
        return batch

    def minibatch(self, batch: Columns, index: Tensor) -> Columns:
        """The rows ``index`` of every column, the advantage standardised per agent slot."""
        out = {g: [column[index] for column in columns] for g, columns in batch.items()}
        for columns in out.values() if self.cfg.algo.normalize_advantage else ():
            adv = columns[4]
            columns[4] = (adv - adv.mean(0)) / (adv.std(0, correction=0) + 1e-8)
        return out

    def loss(self, minibatch: Columns) -> Tensor:
        """Per group the clipped surrogate, the entropy and each critic's squared error,
        weighted -1, -beta and c, summed (per-sample tensors are ``[B, n_g, 1]``)."""
        algo, terms, weights = self.cfg.algo, [], []
        low, high = 1 - algo.clip_epsilon, 1 + algo.clip_epsilon
        for g, net in self.nets.items():
            obs, manager_obs, action, old_log_prob, advantage, target = minibatch[g]
            _, log_prob, entropy = net.policy(obs, action)
            ratio = (log_prob - old_log_prob).exp().clamp(max=algo.max_importance_ratio or math.inf)
            surrogate = torch.minimum(ratio * advantage, ratio.clamp(low, high) * advantage)
            terms += [surrogate.mean(), entropy]
            critics = [(net.worker, obs)] + ([(net.manager, manager_obs)] if net.manager else [])
            terms += [F.mse_loss(critic(x), target) for critic, x in critics]
            weights += [-1.0, -algo.entropy_coef] + [algo.critic_coef] * len(critics)
        return torch.stack(terms) @ torch.tensor(weights)

    def step(self, minibatch: Columns) -> None:
        self.optimizer.zero_grad(set_to_none=True)
        self.loss(minibatch).backward()
        torch.nn.utils.clip_grad_norm_(self.parameters, self.cfg.algo.max_grad_norm)
        self.optimizer.step()

    def update(self, batch: Columns) -> None:
        size, count = self.layout.minibatch_frames, self.layout.minibatches
        for _ in range(self.cfg.algo.epochs):
            for index in torch.randperm(self.layout.frames_per_batch)[: count * size].split(size):
                self.step(self.minibatch(batch, index))

    def flop_per_frame(self) -> float:
        """FLOP of one :meth:`collect` and :meth:`update`, counted on every ``nn.Linear``."""
        from rlhc.building.flops import FLOP_PER_MAC, FORWARD_BACKWARD

        macs = [0]

        def count(layer: Any, inputs: tuple[Tensor, ...], _: Tensor) -> None:
            passes = FORWARD_BACKWARD if torch.is_grad_enabled() else 1
            macs[0] += passes * inputs[0][..., 0].numel() * layer.in_features * layer.out_features

        layers = (m for net in self.nets.values() for m in net.modules())
        hooks = [m.register_forward_hook(count) for m in layers if isinstance(m, nn.Linear)]
        self.update(self.collect())
        for hook in hooks:
            hook.remove()
        return FLOP_PER_MAC * macs[0] / self.layout.frames_per_batch

    def bare_vs_step(self, batch: Columns, reps: int, steps: int = 10) -> tuple[float, float]:
        """Seconds per step of a bare loop over copies of the networks, and the ratio of
        :meth:`step`'s to it: medians over ``reps`` interleaved pairs of ``steps`` steps."""
        minibatch = self.minibatch(batch, torch.arange(self.layout.minibatch_frames))
        pairs = [(copy.deepcopy(net), minibatch[g][index]) for g, nets in self.nets.items()
                 for net, index in ((nets.actor, 0), (nets.worker, 0), (nets.manager, 1)) if net]  # fmt: skip
        bare = [p for net, _ in pairs for p in net.parameters()]
        optimizer = torch.optim.Adam(bare, lr=self.cfg.algo.lr, fused=True)

        def bare_step() -> None:
            optimizer.zero_grad(set_to_none=True)
            torch.stack([net(x).mean() for net, x in pairs]).sum().backward()
            torch.nn.utils.clip_grad_norm_(bare, self.cfg.algo.max_grad_norm)
            optimizer.step()

        times: list[list[float]] = [[], []]
        for _ in range(reps):
            for run, column in ((bare_step, times[0]), (lambda: self.step(minibatch), times[1])):
                start = time.perf_counter()
                for _ in range(steps):
                    run()
                column.append((time.perf_counter() - start) / steps)
        return statistics.median(times[0]), statistics.median(s / b for b, s in zip(*times, strict=True))  # fmt: skip


def run_reference(cfg: Any, updates: int, check_reps: int = 9) -> dict[str, Any]:
    """``updates`` updates; the first (FLOP counted) and the step check are not timed."""
    from rlhc.building.flops import training_flops

    if updates < 2:
        raise ValueError(f"updates={updates}; the reference needs 2 or more (1 warm-up)")
    threads = torch.get_num_threads()
    torch.set_num_threads(cfg.threads if cfg.threads > 0 else threads)
    try:
        loop = Reference(cfg)
        counted = loop.flop_per_frame()
        bare, ratio = loop.bare_vs_step(loop.collect(), check_reps)
        collect_time, start = 0.0, time.perf_counter()
        for _ in range(updates - 1):
            tick = time.perf_counter()
            batch = loop.collect()
            collect_time += time.perf_counter() - tick
            loop.update(batch)
        seconds = time.perf_counter() - start
    finally:
        torch.set_num_threads(threads)
    cost = training_flops(cfg)
    trainer, frames = cost.collection + cost.update, (updates - 1) * loop.layout.frames_per_batch
    step_ok, flop_ok = ratio <= 1 + STEP_TOLERANCE, abs(counted / trainer - 1) <= FLOP_TOLERANCE
    networks = sum(len(list(nets.children())) for nets in loop.nets.values())
    print(f"reference {cfg.env.name}: bare nn.Linear loop of its {networks} networks "
          f"{bare * 1e3:.2f} ms per minibatch step, its own step {ratio:.2f}x that "
          f"({'ok' if step_ok else 'FAILED'}: <= {1 + STEP_TOLERANCE:.2f}x)\n"
          f"reference {cfg.env.name}: {counted / 1e6:.2f} MFLOP per frame counted, "
          f"{counted / trainer:.3f}x the trainer's {trainer / 1e6:.2f} "
          f"({'ok' if flop_ok else 'FAILED'}: within {FLOP_TOLERANCE:.0%})", flush=True)  # fmt: skip
    checks = {"bare_step_ms": 1e3 * bare, "step_ratio": ratio, "step_ok": step_ok,
              "flop_per_frame": counted, "trainer_flop_per_frame": trainer, "flop_ok": flop_ok}  # fmt: skip
    return {"frames_per_s": frames / seconds, "frames": frames, "seconds": seconds,
            "env_steps_per_s": frames / collect_time, "worlds": loop.layout.num_envs,
            "frames_per_batch": loop.layout.frames_per_batch, "checks": checks}  # fmt: skip
