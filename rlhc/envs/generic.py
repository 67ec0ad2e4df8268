"""Any multi-agent environment of PettingZoo or VMAS, in this package's TensorDict contract.

``env=pettingzoo env.factory=<module>:<callable>`` trains on any PettingZoo
``ParallelEnv``; ``env=vmas env.scenario=<name>`` on any VMAS scenario. Both come in
through TorchRL's own wrappers (``PettingZooWrapper`` batched by ``SerialEnv``, and
``VmasEnv``, whose worlds are vectorised on torch), then two transforms put them in
the contract of :mod:`rlhc.envs.torchrl_adapter` that the networks, the estimator and
the trainer read:

* TorchRL's ``StepCounter``: ``"step_count"`` and, with ``env.max_cycles``, truncation;
* :class:`AgentContract`: each agent's manager observation (``env.manager_view``), its
  team (0: these environments have no teams), every group's done flags where the
  environment gives only the world's, the environment's numeric ``info`` entries as
  events (``("info", "<group>_<key>")``, summed over the group's agents), continuous
  actions clipped to their bounds, and the checks that turn a bad environment into one
  line: observations that are NaN or infinite, agents that leave mid-episode.

Groups follow TorchRL's convention (agents named ``<group>_<i>`` grouped by prefix)
unless ``env.groups`` gives them. What these environments lack — a scripted team,
match rules — keeps matches, Elo, showcases and the league with the built-in games.

Examples:
    >>> env = make_source_env("vmas", num_envs=2, seed=0, scenario="navigation")
    >>> td = env.reset()
    >>> td["agents", "observation"].shape, td["agents", "manager_observation"].shape
    (torch.Size([2, 4, 18]), torch.Size([2, 4, 72]))
"""

from __future__ import annotations

import importlib
import warnings
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import torch
from tensordict import TensorDictBase
from torchrl.data import Bounded, Categorical, Composite, Unbounded
from torchrl.envs import Compose, EnvBase, SerialEnv, StepCounter, Transform, TransformedEnv

from rlhc.envs.keys import (
    ACTION,
    DONE,
    DONE_KEYS,
    INFO,
    MANAGER_OBSERVATION,
    OBSERVATION,
    STEP_COUNT,
    TEAM,
    TERMINATED,
    TRUNCATED,
)
from rlhc.errors import ConfigError, EnvError

#: ``env.manager_view`` values besides ``<module>:<callable>``.
TEAM_VIEW = "team"
WORLD_VIEW = "world"
STATE_VIEW = "state"
#: The views that are the same for every agent of a group: the manager critic runs once
#: per world (:func:`~rlhc.modules.make_manager_critic`'s ``shared_view``).
SHARED_VIEWS = (WORLD_VIEW, STATE_VIEW)
#: The root key of the environment's global state (TorchRL's ``return_state=True``).
STATE = "state"

#: A manager view: one step's observations -> each agent's manager observation.
ManagerView = Callable[[Mapping[str, torch.Tensor]], Mapping[str, torch.Tensor]]


def load_callable(spec: str, key: str) -> Callable[..., Any]:
    """The callable ``<module>:<name>`` names (``<name>`` may be dotted).

    Raises:
        ConfigError: ``spec`` is not of that form, the module does not import, or it
            has no such callable; the message names ``key`` and the cause.

    Examples:
        >>> load_callable("math:sqrt", "env.factory")(4.0)
        2.0
        >>> load_callable("math.sqrt", "env.factory")
        Traceback (most recent call last):
        ...
        rlhc.errors.ConfigError: env.factory='math.sqrt'; allowed: <module>:<callable>, e.g. mpe2.simple_spread_v3:parallel_env
    """
    module_name, colon, name = spec.partition(":")
    if not colon or not module_name or not name:
        raise ConfigError(
            f"{key}={spec!r}; allowed: <module>:<callable>, e.g. mpe2.simple_spread_v3:parallel_env"
        )
    try:
        target: Any = importlib.import_module(module_name)
    except Exception as error:  # an import may fail in any way: report it in one line
        raise ConfigError(
            f"{key}={spec!r}: module {module_name!r} does not import "
            f"({type(error).__name__}: {error})"
        ) from error
    for part in name.split("."):
        if not hasattr(target, part):
            raise ConfigError(f"{key}={spec!r}: {module_name!r} has no attribute {name!r}")
        target = getattr(target, part)
    if not callable(target):
        raise ConfigError(f"{key}={spec!r}: {name!r} is a {type(target).__name__}, not callable")
    return target


# --- the contract ------------------------------------------------------------------------
class AgentContract(Transform):
    """The per-agent entries this package reads, added to a TorchRL multi-agent env.

    Args:
        groups: the env's groups (the top-level entries of its action spec).
        manager_view: ``"team"``, ``"world"``, ``"state"`` or a :data:`ManagerView`
            callable.
        source: the environment's name in messages (e.g. ``"vmas navigation"``).
    """

    def __init__(self, groups: Sequence[str], manager_view: str | ManagerView, source: str) -> None:
        super().__init__()
        self.groups = list(groups)
        self.manager_view = manager_view
        self.source = source
        self._own_dones: dict[str, bool] = {}
        self._info: dict[str, list[str]] = {}
        self._bounds: dict[str, tuple[torch.Tensor, torch.Tensor]] = {}
        self._order: dict[str, torch.Tensor] = {}

    # --- specs ---------------------------------------------------------------------------
    def transform_observation_spec(self, observation_spec: Composite) -> Composite:
        batch = observation_spec.shape
        observations = {}
        for group in self.groups:
            spec = observation_spec[group]
            leaf = spec.get(OBSERVATION, None) if isinstance(spec, Composite) else None
            if leaf is None or leaf.ndim != len(spec.shape) + 1:
                raise ConfigError(
                    f"{self.source}: group {group!r} observes {_described(spec)}; allowed: "
                    f"one flat observation vector per agent ({(group, OBSERVATION)!r} of "
                    "shape [..., agents, size])"
                )
            observations[group] = leaf.zero()
            info = spec.get(INFO, None)
            self._info[group] = [
                key
                for key, value in (info.items() if isinstance(info, Composite) else ())
                if not isinstance(value, Composite) and value.dtype.is_floating_point
            ]
        views = self.manager_views(observations, observation_spec.zero())
        for group in self.groups:
            agents = observation_spec[group].shape
            view = views[group]
            observation_spec[group, MANAGER_OBSERVATION] = Unbounded(
                view.shape, dtype=torch.float32, device=observation_spec.device
            )
            observation_spec[group, TEAM] = Bounded(
                0, 1, (*agents, 1), dtype=torch.int64, device=observation_spec.device
            )
        events = {
            f"{group}_{key}": Unbounded(batch, dtype=torch.float32, device=observation_spec.device)
            for group, keys in self._info.items()
            for key in keys
        }
        if events:
            observation_spec[INFO] = Composite(events, shape=batch)
        return observation_spec

    def transform_done_spec(self, done_spec: Composite) -> Composite:
        batch = done_spec.shape
        for key in DONE_KEYS:
            if done_spec.get(key, None) is None:
                done_spec[key] = Categorical(
                    2, (*batch, 1), dtype=torch.bool, device=done_spec.device
                )
        parent = self.parent
        assert parent is not None
        action_spec = parent.full_action_spec
        for group in self.groups:
            agents = action_spec[group].shape
            own = done_spec.get((group, DONE), None) is not None
            self._own_dones[group] = own
            for key in DONE_KEYS:
                if (group, key) not in done_spec.keys(include_nested=True):
                    done_spec[group, key] = Categorical(
                        2, (*agents, 1), dtype=torch.bool, device=done_spec.device
                    )
        return done_spec

    # --- the manager's view --------------------------------------------------------------
    def manager_views(
        self, observations: Mapping[str, torch.Tensor], tensordict: TensorDictBase
    ) -> dict[str, torch.Tensor]:
        """``{group: [*B, n_g, d_m]}`` of one step's ``observations`` (``tensordict``
        holds the rest of the step, e.g. the global state)."""
        if self.manager_view == TEAM_VIEW:
            return {group: self._team_view(group, obs) for group, obs in observations.items()}
        if self.manager_view == WORLD_VIEW:
            return {
                group: obs.flatten(-2).unsqueeze(-2).expand(*obs.shape[:-1], -1)
                for group, obs in observations.items()
            }
        if self.manager_view == STATE_VIEW:
            state = tensordict.get(STATE).to(torch.float32)
            return {
                group: state.unsqueeze(-2).expand(*obs.shape[:-1], state.shape[-1])
                for group, obs in observations.items()
            }
        assert callable(self.manager_view)
        return self._user_view(observations)

    def _team_view(self, group: str, observation: torch.Tensor) -> torch.Tensor:
        order = self._order.get(group)
        n = observation.shape[-2]
        if order is None:
            # Row i: agent i, then i + 1, ..., wrapping round.
            order = (torch.arange(n).unsqueeze(1) + torch.arange(n)) % n
            self._order[group] = order
        return observation[..., order, :].flatten(-2)

    def _user_view(self, observations: Mapping[str, torch.Tensor]) -> dict[str, torch.Tensor]:
        assert callable(self.manager_view)
        name = getattr(self.manager_view, "__qualname__", repr(self.manager_view))
        try:
            views = self.manager_view(observations)
        except Exception as error:
            raise EnvError(
                f"env.manager_view={name}: failed on a step's observations "
                f"({type(error).__name__}: {error})"
            ) from error
        checked = {}
        for group, obs in observations.items():
            view = views.get(group) if isinstance(views, Mapping) else None
            if (
                not isinstance(view, torch.Tensor)
                or view.ndim != obs.ndim
                or view.shape[:-1] != obs.shape[:-1]
            ):
                shown = tuple(view.shape) if isinstance(view, torch.Tensor) else type(view).__name__
                raise EnvError(
                    f"env.manager_view={name}: for group {group!r} it returned {shown}; "
                    f"allowed: a tensor of shape {(*obs.shape[:-1], 'd_m')} (one manager "
                    "observation per agent)"
                )
            checked[group] = view.to(torch.float32)
        return checked

    # --- each step -------------------------------------------------------------------------
    def _reset(
        self, tensordict: TensorDictBase, tensordict_reset: TensorDictBase
    ) -> TensorDictBase:
        return self.complete(tensordict_reset)

    def _call(self, next_tensordict: TensorDictBase) -> TensorDictBase:
        return self.complete(next_tensordict)

    def complete(self, next_tensordict: TensorDictBase) -> TensorDictBase:
        """Add the contract's entries to one step's (or reset's) output, after checking
        its observations; raises :class:`~rlhc.errors.EnvError` where it breaks it."""
        observations = {}
        for group in self.groups:
            observation = next_tensordict.get((group, OBSERVATION))
            if not torch.isfinite(observation).all():
                self._not_finite(group, observation, next_tensordict)
            observations[group] = observation
        for group, view in self.manager_views(observations, next_tensordict).items():
            next_tensordict.set((group, MANAGER_OBSERVATION), view)
        done = next_tensordict.get(DONE)
        if next_tensordict.get(TRUNCATED, None) is None:
            next_tensordict.set(TRUNCATED, torch.zeros_like(done))
        if next_tensordict.get(TERMINATED, None) is None:
            next_tensordict.set(TERMINATED, done.clone())
        events = {}
        for group, observation in observations.items():
            agents = observation.shape[:-1]
            next_tensordict.set(
                (group, TEAM),
                torch.zeros((*agents, 1), dtype=torch.int64, device=observation.device),
            )
            if self._own_dones.get(group):
                agent_done = next_tensordict.get((group, DONE))
                if (agent_done.squeeze(-1) != done).any():
                    self._left(group, agent_done, done, next_tensordict)
            else:
                for key in DONE_KEYS:
                    flag = next_tensordict.get(key)
                    next_tensordict.set((group, key), flag.unsqueeze(-2).expand(*agents, 1).clone())
            for key in self._info.get(group, ()):
                value = next_tensordict.get((group, "info", key))
                events[f"{group}_{key}"] = value.reshape(*agents, -1).sum(dim=(-2, -1))
        if events:
            for key, value in events.items():
                next_tensordict.set((INFO, key), value.to(torch.float32))
        return next_tensordict

    def _inv_call(self, tensordict: TensorDictBase) -> TensorDictBase:
        # Continuous actions clipped to their bounds, as the built-in games do (a
        # Gaussian policy may sample outside them); the rollout keeps what was sampled.
        if not self._bounds:
            parent = self.parent
            assert parent is not None
            for group in self.groups:
                spec = parent.full_action_spec[group, ACTION]
                if isinstance(spec, Bounded) and spec.dtype.is_floating_point:
                    self._bounds[group] = (spec.space.low, spec.space.high)
        for group, (low, high) in self._bounds.items():
            action = tensordict.get((group, ACTION))
            tensordict.set((group, ACTION), torch.maximum(torch.minimum(action, high), low))
        return tensordict

    # --- what is refused -------------------------------------------------------------------
    def _not_finite(self, group: str, observation: torch.Tensor, td: TensorDictBase) -> None:
        bad = (~torch.isfinite(observation)).flatten(-1).any(-1).nonzero()[0].tolist()
        *world, agent = bad
        step = _step_of(td, world)
        raise EnvError(
            f"{self.source}: agent {group}_{agent}'s observation is NaN or infinite at "
            f"step {step}{_world(world)}; a policy cannot learn from it: fix the "
            "environment or its wrapper"
        )

    def _left(
        self, group: str, agent_done: torch.Tensor, done: torch.Tensor, td: TensorDictBase
    ) -> None:
        differs = (agent_done.squeeze(-1) != done).nonzero()[0].tolist()
        *world, agent = differs
        step = _step_of(td, world)
        raise EnvError(
            f"{self.source}: agent {group}_{agent} "
            + ("left" if bool(agent_done[tuple(differs)].item()) else "played on")
            + f" at step {step}{_world(world)} while the other agents of its world did not; "
            "allowed: environments whose agents all end an episode together (make the "
            "leaving agent wait with a no-op until the episode ends)"
        )


def _step_of(td: TensorDictBase, world: list[int]) -> int | str:
    count = td.get(STEP_COUNT, None)
    if count is not None:
        return int(count[tuple(world)].item())
    return "?"


def _world(world: list[int]) -> str:
    return f" of world {world[0]}" if world else ""


def _described(spec: Any) -> str:
    if isinstance(spec, Composite):
        return "{" + ", ".join(sorted(str(key) for key in spec)) + "}"
    return type(spec).__name__


# --- the sources -----------------------------------------------------------------------
def _manager_view(manager_view: str) -> str | ManagerView:
    if manager_view in (TEAM_VIEW, WORLD_VIEW, STATE_VIEW):
        return manager_view
    if ":" not in manager_view:
        raise ConfigError(
            f"env.manager_view={manager_view!r}; allowed: {TEAM_VIEW}, {WORLD_VIEW}, "
            f"{STATE_VIEW} or <module>:<callable>"
        )
    return load_callable(manager_view, "env.manager_view")


def _check_pettingzoo(env: Any, factory: str) -> None:
    """Refuse, in one line, a PettingZoo env whose spaces the networks cannot use."""
    from gymnasium import spaces
    from pettingzoo import AECEnv

    if isinstance(env, AECEnv):
        raise ConfigError(
            f"env.factory={factory!r} returned an AEC env ({type(env).__name__}); allowed: "
            "a ParallelEnv (PettingZoo's aec_to_parallel converts one)"
        )
    if not hasattr(env, "possible_agents") or not hasattr(env, "observation_space"):
        raise ConfigError(
            f"env.factory={factory!r} returned a {type(env).__name__}; allowed: a "
            "PettingZoo ParallelEnv"
        )
    for agent in env.possible_agents:
        observation = env.observation_space(agent)
        if not isinstance(observation, spaces.Box) or len(observation.shape) != 1:
            raise ConfigError(
                f"env.factory={factory!r}: agent {agent!r} observes {observation}; "
                "supported: a 1-D Box (flatten other spaces in a wrapper)"
            )
        action = env.action_space(agent)
        if not (
            isinstance(action, spaces.Discrete)
            or (isinstance(action, spaces.Box) and len(action.shape) == 1)
        ):
            raise ConfigError(
                f"env.factory={factory!r}: agent {agent!r} acts in {action}; supported: "
                "Discrete or a 1-D Box"
            )


def make_pettingzoo_env(
    *,
    factory: str,
    num_envs: int,
    seed: int | None,
    manager_view: str = TEAM_VIEW,
    groups: Mapping[str, Sequence[str]] | None = None,
    kwargs: Mapping[str, Any] | None = None,
    max_cycles: int | None = None,
    device: str | torch.device = "cpu",
) -> TransformedEnv:
    """``num_envs`` copies of the ``ParallelEnv`` ``factory`` returns, as one batched env.

    Raises:
        ConfigError: the factory does not import, returns something else than a
            ``ParallelEnv``, an agent's space is not supported, or ``manager_view=state``
            on an env without a ``state()``.
    """
    create = load_callable(factory, "env.factory")
    options = dict(kwargs or {})
    view = _manager_view(manager_view)

    def build() -> EnvBase:
        from torchrl.envs.libs.pettingzoo import PettingZooWrapper

        try:
            env = create(**options)
        except Exception as error:
            raise ConfigError(
                f"env.factory={factory!r} with env.kwargs={options}: "
                f"{type(error).__name__}: {error}"
            ) from error
        _check_pettingzoo(env, factory)
        if view == STATE_VIEW and getattr(env, "state_space", None) is None:
            raise ConfigError(
                f"env.manager_view=state: {factory} has no state() (no state_space); "
                f"allowed: {TEAM_VIEW}, {WORLD_VIEW} or <module>:<callable>"
            )
        with warnings.catch_warnings():
            # TorchRL names the PettingZoo release it was tested with, once per copy.
            warnings.filterwarnings("ignore", message="PettingZoo in TorchRL is tested")
            return PettingZooWrapper(
                env,
                return_state=view == STATE_VIEW,
                group_map=None if groups is None else {g: list(a) for g, a in groups.items()},
                categorical_actions=True,
                use_mask=False,
                done_on_any=False,
                device=device,
            )

    build()  # a bad env fails here, in one line, before the workers start
    base = SerialEnv(num_envs, build)
    return _with_contract(base, view, max_cycles, f"pettingzoo {factory}", seed)


def make_vmas_env(
    *,
    scenario: str,
    num_envs: int,
    seed: int | None,
    manager_view: str = TEAM_VIEW,
    groups: Mapping[str, Sequence[str]] | None = None,
    kwargs: Mapping[str, Any] | None = None,
    max_cycles: int | None = None,
    continuous_actions: bool = True,
    device: str | torch.device = "cpu",
) -> TransformedEnv:
    """``num_envs`` vectorised worlds of the VMAS ``scenario`` (TorchRL's ``VmasEnv``).

    Raises:
        ConfigError: VMAS is not installed, the scenario is unknown, or
            ``manager_view=state`` (VMAS scenarios have no global state).
    """
    try:
        import vmas
        from torchrl.envs.libs.vmas import VmasEnv
    except ImportError as error:
        raise ConfigError(
            f"env=vmas needs the vmas package ({error}); install it with pip install -e .[envs]"
        ) from error
    view = _manager_view(manager_view)
    if view == STATE_VIEW:
        raise ConfigError(
            "env.manager_view=state: VMAS scenarios have no global state(); allowed: "
            f"{TEAM_VIEW}, {WORLD_VIEW} or <module>:<callable>"
        )
    known = sorted({*vmas.scenarios, *vmas.mpe_scenarios, *vmas.debug_scenarios})
    if scenario not in known:
        raise ConfigError(f"env.scenario={scenario!r}; allowed: one of {', '.join(known)}")
    try:
        base = VmasEnv(
            scenario,
            num_envs=num_envs,
            continuous_actions=continuous_actions,
            max_steps=None,  # truncation by StepCounter: GAE bootstraps a cut episode
            seed=seed,
            device=device,
            group_map=None if groups is None else {g: list(a) for g, a in groups.items()},
            categorical_actions=True,
            **dict(kwargs or {}),
        )
    except (TypeError, ValueError, KeyError) as error:
        raise ConfigError(
            f"env=vmas env.scenario={scenario} env.kwargs={dict(kwargs or {})}: "
            f"{type(error).__name__}: {error}"
        ) from error
    return _with_contract(base, view, max_cycles, f"vmas {scenario}", None)


def _with_contract(
    base: EnvBase, view: str | ManagerView, max_cycles: int | None, source: str, seed: int | None
) -> TransformedEnv:
    groups = [str(group) for group in base.full_action_spec.keys(include_nested=False)]
    for group in groups:
        spec = base.full_action_spec[group, ACTION]
        if not isinstance(spec, Bounded | Categorical):
            raise ConfigError(
                f"{source}: group {group!r} acts in {type(spec).__name__}; supported: "
                "Discrete or a 1-D Box"
            )
    env = TransformedEnv(
        base, Compose(StepCounter(max_steps=max_cycles), AgentContract(groups, view, source))
    )
    env.observation_spec  # noqa: B018 (builds the specs: a bad manager view fails here)
    if seed is not None:
        env.set_seed(seed)
    return env


#: ``env=<name>`` -> its builder.
SOURCES: dict[str, Callable[..., TransformedEnv]] = {
    "pettingzoo": make_pettingzoo_env,
    "vmas": make_vmas_env,
}


def rendering_options(name: str, options: Mapping[str, Any]) -> dict[str, Any]:
    """``options`` of source ``name`` with what makes its worlds render RGB frames
    (:func:`render_frame`): PettingZoo's ``render_mode="rgb_array"`` among the factory's
    keyword arguments; VMAS renders on request."""
    if name != "pettingzoo":
        return dict(options)
    return {**options, "kwargs": {**(options.get("kwargs") or {}), "render_mode": "rgb_array"}}


def render_frame(env: EnvBase, name: str) -> np.ndarray:
    """World 0 of ``env`` (of source ``name``, built with :func:`rendering_options`) as an
    ``uint8 [H, W, 3]`` image, drawn by the environment's own renderer.

    Raises:
        EnvError: the environment draws no RGB frame.
    """
    base = env.base_env if isinstance(env, TransformedEnv) else env
    # VMAS draws a world on request; a SerialEnv of PettingZoo worlds returns each one's.
    frame = base.render(mode="rgb_array", env_index=0) if name == "vmas" else base.render()[0]
    image = None if frame is None else np.asarray(frame)
    if image is None or image.ndim != 3 or image.shape[-1] != 3:
        drawn = "nothing" if image is None else f"an array of shape {list(image.shape)}"
        raise EnvError(
            f"env={name}: the environment drew {drawn} for a frame; allowed: an RGB array "
            "[height, width, 3] (a PettingZoo env that takes render_mode='rgb_array')"
        )
    return image.astype(np.uint8, copy=False)


def make_source_env(
    name: str,
    num_envs: int = 1,
    seed: int | None = None,
    device: str | torch.device = "cpu",
    **options: Any,
) -> TransformedEnv:
    """The environment of source ``name`` (``pettingzoo`` or ``vmas``) with its options.

    Raises:
        ConfigError: an option the source does not take, or any of its builder's.
    """
    options = dict(options)
    kwargs = options.get("kwargs")
    if kwargs is not None and not isinstance(kwargs, Mapping):
        raise ConfigError(f"env.kwargs={kwargs!r}; allowed: null or a mapping, e.g. '{{N: 3}}'")
    groups = options.get("groups")
    if groups is not None and not (
        isinstance(groups, Mapping)
        and all(isinstance(a, Sequence) and not isinstance(a, str) for a in groups.values())
    ):
        raise ConfigError(
            f"env.groups={groups!r}; allowed: null or a mapping of group names to agent "
            "lists, e.g. '{blue: [blue_0, blue_1], red: [red_0, red_1]}'"
        )
    interval = options.pop("decision_interval", None)
    if interval is not None:
        raise ConfigError(
            f"env.decision_interval={interval} on env={name}; allowed: null (the "
            "environment decides how long a step lasts)"
        )
    return SOURCES[name](num_envs=num_envs, seed=seed, device=device, **options)


__all__ = [
    "SOURCES",
    "AgentContract",
    "load_callable",
    "make_pettingzoo_env",
    "make_source_env",
    "make_vmas_env",
    "render_frame",
    "rendering_options",
]
