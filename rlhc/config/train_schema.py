"""Hydra schemas of a training run, registered in Hydra's ConfigStore.

Every yaml file in ``conf/`` names one of these schemas in its defaults list, so a
misspelt key or a value of the wrong type fails before anything is built. The paper's
Table 3 values live only in ``conf/table3/<env>.yaml`` (``MISSING`` here); the defaults
here are the settings the paper does not give. Each ``Attributes:`` line is a row of the
settings table of ``docs/guide/configuration.md`` (:mod:`rlhc.config.table`).

Every section has its schema here, so that the schemas and their checks import nothing
of the code they configure; only the game options (:mod:`rlhc.envs.schemas`) and the
network settings (:mod:`rlhc.modules.schemas`), read by their own floors, live there.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from hydra.core.config_store import ConfigStore
from omegaconf import MISSING, OmegaConf

from rlhc.modules.schemas import NetworkConfig

#: ``resume=auto``: continue from the run directory's own checkpoint, if it holds one.
RESUME_AUTO = "auto"
#: The Hydra configs: ``conf/`` next to the package.
CONFIG_DIR = Path(__file__).resolve().parents[2] / "conf"


def measured_in(unit: str, default: Any = MISSING) -> Any:
    """A schema field with its unit (shown in the settings table)."""
    return field(default=default, metadata={"unit": unit})


@dataclass
class CriticConfig:
    """How the worker and manager critics are fused into the value used by GAE.

    Attributes:
        fusion: ``local`` (worker critic only: PPO), ``manager`` (manager critic only),
            ``max`` (RLHC: element-wise ``max(V_w, V_m)``), ``mean`` or ``weighted``.
        weight: manager weight ``w`` of ``weighted``: ``w·V_m + (1 - w)·V_w``, in [0, 1].
        manager_interval: the manager is consulted every ``k`` steps (temporal scaling).
        manager_view: the second critic reads the manager's observation (RLHC); ``false``:
            the *twin* control (``critic=twin``), a second critic on the worker's own view.
        manager_diagnostics: with ``fusion=local`` (PPO), still train and log the manager critic.
        worker_diagnostics: with ``fusion=manager`` (consulted every step), still train and
            log the worker critic, which ``V_hat`` does not read.
    """

    fusion: str = "max"
    weight: float = 0.5
    manager_interval: int = measured_in("decisions", 1)
    manager_view: bool = True
    manager_diagnostics: bool = False
    worker_diagnostics: bool = False


@dataclass
class PPOConfig:
    """PPO hyperparameters (paper Table 3), in the units of ML-Agents 0.5, its trainer.

    A *world-decision* (a "frame" in ``metrics.csv``) is one decision of every agent of
    one court or pitch; an *agent-experience* is one agent's one decision.

    Attributes:
        max_steps: the budget (the paper's ``max_steps`` × the worlds of its scene).
        buffer_size: agent-experiences per group that one update trains on.
        time_horizon: decisions after which a trajectory is cut and GAE bootstraps.
        batch_size: agent-experiences per group in one minibatch (a multiple of its agents).
        epochs: passes over each buffer.
        lr: Adam learning rate.
        anneal_lr: decay the learning rate linearly to ``final_lr`` over ``max_steps``.
        anneal_entropy_coef: decay ``entropy_coef`` linearly to ``final_entropy_coef``.
        anneal_clip_epsilon: decay ``clip_epsilon`` linearly to ``final_clip_epsilon``.
        final_lr: the annealed learning rate's floor (ML-Agents 0.5: 1e-10).
        final_entropy_coef: the annealed entropy coefficient's floor (ML-Agents 0.5: 1e-5).
        final_clip_epsilon: the annealed clip range's floor (ML-Agents 0.5: 0.1).
        gamma: discount per decision.
        lmbda: GAE lambda.
        clip_epsilon: PPO ratio clip.
        entropy_coef: the paper's ``beta``.
        critic_coef: weight of each critic's value loss.
        max_grad_norm: global gradient-norm clip.
        normalize_advantage: standardise advantages per minibatch.
        max_importance_ratio: cap of the ratio ``pi / pi_old`` against NaN weights (``null``: none).
        normalize_observations: running mean/std normalisation of observations (``normalize``).
        target_kl: ``null``, or the KL per update the learning rate adapts to (:func:`adapted_lr`).
        min_lr: the adapted learning rate's floor (``target_kl`` only).
        observation_decay: the normaliser's decay per world-decision (1: cumulative, ML-Agents 0.5).
        observation_clip: ``null``, or the bound of the normalised observations (ML-Agents 0.5: 5).
    """

    max_steps: int = measured_in("world-decisions", MISSING)
    buffer_size: int = measured_in("agent-experiences per group", MISSING)
    time_horizon: int = measured_in("decisions", MISSING)
    batch_size: int = measured_in("agent-experiences per group", MISSING)
    epochs: int = measured_in("passes per update", MISSING)
    lr: float = MISSING
    anneal_lr: bool = MISSING
    anneal_entropy_coef: bool = MISSING
    anneal_clip_epsilon: bool = MISSING
    final_lr: float = 0.0
    final_entropy_coef: float = 1e-5
    final_clip_epsilon: float = 0.1
    gamma: float = measured_in("per decision", MISSING)
    lmbda: float = MISSING
    clip_epsilon: float = MISSING
    entropy_coef: float = MISSING
    critic_coef: float = 0.5
    max_grad_norm: float = 0.5
    normalize_advantage: bool = True
    max_importance_ratio: float | None = 100.0
    normalize_observations: bool = MISSING
    target_kl: float | None = None
    min_lr: float = 1e-6
    observation_decay: float = 0.99999
    observation_clip: float | None = None


#: The factor by which :func:`adapted_lr` moves the learning rate (rsl_rl, rl_games).
LR_ADAPTATION_FACTOR = 1.5


def schedules(algo: PPOConfig, frames: int) -> tuple[float, float, float]:
    """Learning rate, entropy coefficient and clip range after ``frames`` world-decisions.

    As ML-Agents 0.5: each annealed one decays linearly over the budget to its floor.

    Examples:
        >>> from rlhc.config.train_schema import PPOConfig
        >>> algo = PPOConfig(max_steps=100, lr=1e-3, entropy_coef=0.01, clip_epsilon=0.2,
        ...                  anneal_lr=True, anneal_entropy_coef=True, anneal_clip_epsilon=True)
        >>> schedules(algo, 50)
        (0.0005, 0.005005, 0.15000000000000002)
    """
    progress = min(1.0, frames / algo.max_steps)
    lr = algo.lr
    if algo.anneal_lr:
        lr = algo.lr * (1.0 - progress) + algo.final_lr * progress
    entropy_coef = algo.entropy_coef
    if algo.anneal_entropy_coef:
        entropy_coef += (algo.final_entropy_coef - entropy_coef) * progress
    clip_epsilon = algo.clip_epsilon
    if algo.anneal_clip_epsilon:
        clip_epsilon += (algo.final_clip_epsilon - clip_epsilon) * progress
    return lr, entropy_coef, clip_epsilon


def adapted_lr(lr: float, kl: float, algo: PPOConfig) -> float:
    """The learning rate after an update whose mean KL was ``kl`` (``algo.target_kl``).

    Down by :data:`LR_ADAPTATION_FACTOR` above twice the target, up by it below half of
    it, unchanged in between (and on a NaN KL); always within ``[algo.min_lr, algo.lr]``.

    Examples:
        >>> algo = PPOConfig(lr=1e-3, target_kl=0.01, min_lr=1e-6)
        >>> round(adapted_lr(1e-3, 0.05, algo), 10)  # above twice the target: down
        0.0006666667
        >>> round(adapted_lr(1e-4, 0.001, algo), 10)  # under half of it: up
        0.00015
        >>> adapted_lr(1e-4, 0.01, algo), adapted_lr(1e-3, 0.0, algo)  # kept; capped at lr
        (0.0001, 0.001)
    """
    if algo.target_kl is None:
        raise ValueError("adapted_lr needs algo.target_kl (it is null: the rate is not adapted)")
    if kl > 2.0 * algo.target_kl:
        lr /= LR_ADAPTATION_FACTOR
    elif kl < algo.target_kl / 2.0:
        lr *= LR_ADAPTATION_FACTOR
    return min(algo.lr, max(algo.min_lr, lr))


@dataclass
class ModelConfig(NetworkConfig):
    """The ``model`` section: :class:`~rlhc.modules.NetworkConfig`, its shape set by a preset."""

    num_layers: int = MISSING
    hidden_size: int = MISSING
    activation: str = MISSING


@dataclass
class LoggerConfig:
    """Where metrics go.

    Attributes:
        backends: any of ``csv`` (``metrics.csv``, always written), ``tensorboard``, ``wandb``.
        summary_freq: log after every update that crosses a multiple of this.
        progress: show a progress bar (``None``: only when stderr is a terminal).
        wandb_project: wandb project name.
        wandb_mode: ``auto`` (online given an API key), ``online``, ``offline`` or ``disabled``.
    """

    backends: list[str] = field(default_factory=lambda: ["csv", "tensorboard"])
    summary_freq: int = measured_in("world-decisions", MISSING)
    progress: bool | None = None
    wandb_project: str = "rlhc"
    wandb_mode: str = "auto"


@dataclass
class LeagueConfig:
    """Who the learning team plays (the shares of the training worlds; beyond the paper).

    Attributes:
        self_play: share of worlds where both teams are the learning policy.
        snapshot: share of worlds against frozen past learners.
        scripted: share of worlds against the scripted team.
        random: share of worlds against the random team.
        pool_size: snapshots kept (the newest; the oldest is dropped).
        snapshot_interval: updates between two snapshots (the first after this many).
        sampling: ``uniform`` over the pool, or ``elo``: harder snapshots more often.
    """

    self_play: float = 1.0
    snapshot: float = 0.0
    scripted: float = 0.0
    random: float = 0.0
    pool_size: int = 10
    snapshot_interval: int = 10
    sampling: str = "uniform"

    @property
    def shares(self) -> dict[str, float]:
        return {
            "self": self.self_play,
            "snapshot": self.snapshot,
            "scripted": self.scripted,
            "random": self.random,
        }

    @property
    def active(self) -> bool:
        """Whether any world plays someone other than the learner itself."""
        return self.self_play < 1.0


@dataclass
class ShapingConfig:
    """Potential-based shaping (beyond the paper).

    Attributes:
        scale: the potential's weight ``c`` (``F = c (γ Φ(s') − Φ(s))``); 0 turns it off.
    """

    scale: float = 0.0


@dataclass
class TrainConfig:
    """A whole training run.

    Attributes:
        env: the game (group ``env``: ``tennis`` or ``soccer``).
        critic: the value fusion (group ``critic``).
        algo: PPO hyperparameters (Table 3 per env, group ``table3`` chooses them).
        model: the networks (group ``model``).
        logger: metrics backends (group ``logger``).
        shaping: potential-based reward shaping (beyond the paper; off at scale 0).
        league: who the learning team plays (group ``league``; ``self_play`` is the paper's).
        seed: seeds torch, numpy and the game.
        checkpoint_freq: save a checkpoint after every update that crosses a multiple of this.
        resume: ``null``: start fresh; a checkpoint file or run directory: continue it;
            ``auto``: continue from this run's own directory if it holds a checkpoint.
        device: where the networks and the update run: ``cpu``, ``cuda`` or ``cuda:<index>``.
        threads: torch intra-op threads (``0``: leave torch's default).
        compile: run each minibatch's loss and backward under ``torch.compile``: faster,
            but a seeded run reproduces only eagerly (``docs/guide/performance.md``).
        eval_freq: every this many, log the win rate against the scripted team (``0``: never).
        eval_matches: matches per periodic evaluation (half on each side).
        play_freq: every this many, log under ``play/`` how the policy plays itself (``0``: never).
        play_worlds: worlds of each periodic play measurement.
        play_decisions: decisions per world of each periodic play measurement.
        parallel: how the processes of ``torchrun`` share a run
            (:mod:`rlhc.training.distributed`): ``data`` (gradients all-reduced: the same
            update as one process) or ``pipeline`` (rank 0 updates while rank 1 collects).
    """

    env: Any = MISSING
    critic: CriticConfig = field(default_factory=CriticConfig)
    algo: PPOConfig = field(default_factory=PPOConfig)
    model: ModelConfig = field(default_factory=ModelConfig)
    logger: LoggerConfig = field(default_factory=LoggerConfig)
    league: LeagueConfig = field(default_factory=LeagueConfig)
    shaping: ShapingConfig = field(default_factory=ShapingConfig)
    seed: int = 0
    checkpoint_freq: int = measured_in("world-decisions", MISSING)
    resume: str | None = None
    device: str = "cpu"
    threads: int = 1
    compile: bool = False
    eval_freq: int = measured_in("world-decisions", 0)
    eval_matches: int = 20
    play_freq: int = measured_in("world-decisions", 0)
    play_worlds: int = 16
    play_decisions: int = 500
    parallel: str = "data"


def register_configs() -> None:
    """Register the schemas (each game's as ``env/<game>_schema``, each env source's as
    ``env/<source>_schema``) for the yaml files."""
    from rlhc.envs.registry import game_spec, games
    from rlhc.envs.schemas import SOURCE_SCHEMAS

    cs = ConfigStore.instance()
    cs.store(name="train_schema", node=TrainConfig)
    for name in games():
        cs.store(group="env", name=f"{name}_schema", node=game_spec(name).env_config)
    for name, schema in SOURCE_SCHEMAS.items():
        cs.store(group="env", name=f"{name}_schema", node=schema)
    cs.store(group="critic", name="critic_schema", node=CriticConfig)
    cs.store(group="logger", name="logger_schema", node=LoggerConfig)
    cs.store(group="league", name="league_schema", node=LeagueConfig)


def compose_config(*overrides: str) -> TrainConfig:
    """The training config ``python -m rlhc.run <overrides>`` composes, checked by the schemas.

    For scripts, notebooks and examples; without Hydra's node, the entry point's checks
    (:func:`rlhc.config.validation.validate`) and ``resume=auto``'s resolution.

    Raises:
        hydra.errors.HydraException, omegaconf.errors.OmegaConfBaseException: an
            override that does not compose.

    Examples:
        >>> cfg = compose_config("env=soccer", "experiment=smoke")
        >>> cfg.env.name, cfg.critic.fusion, cfg.algo.max_steps
        ('soccer', 'max', 512)
    """
    from hydra import compose, initialize_config_dir

    register_configs()
    with initialize_config_dir(config_dir=str(CONFIG_DIR), version_base="1.3"):
        cfg = compose(config_name="train", overrides=list(overrides))
    return OmegaConf.to_object(cfg)  # type: ignore[return-value]
