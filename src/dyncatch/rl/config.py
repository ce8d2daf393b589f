"""PPO hyper-parameters and batch geometry."""

from __future__ import annotations

from flax import struct

from dyncatch.sim.config import static
from dyncatch.sim.validate import non_finite_fields


@struct.dataclass
class PPOCfg:
    num_envs: int = static(512)
    """Parallel environments per rollout."""
    num_steps: int = static(32)
    """Control steps per environment per rollout (the batch is num_envs * num_steps)."""
    num_minibatches: int = static(4)
    """Minibatches per epoch; must divide the batch."""
    update_epochs: int = static(4)
    """Passes over each rollout."""
    hidden_sizes: tuple[int, ...] = static((128, 128, 64))
    """Hidden layers of the actor and of the critic (ELU). The paper gives no size: a named
    choice, by the criterion written before its study ran (benchmarks/network_size_study.py;
    its summary in benchmarks/results/network_size/summary.md): the smallest of 256-256-128,
    128-128-64 and 64-64 whose every method's success at 1.8 m/s is within 0.05 of
    256-256-128's and whose oracle reaches the same plateau."""
    gamma: float = 0.99
    """Discount per control step (0.02 s)."""
    gae_lambda: float = 0.95
    """GAE lambda."""
    clip_eps: float = 0.2
    """PPO ratio clip."""
    value_clip_eps: float = 0.2
    """Clip of the value update around the old prediction."""
    vf_coef: float = 1.0
    """Weight of the value loss."""
    ent_coef: float = 0.005
    """Weight of the entropy bonus."""
    max_grad_norm: float = 1.0
    """Global gradient-norm clip."""
    learning_rate: float = 1e-3
    """Initial Adam learning rate (then adapted by the KL rule)."""
    desired_kl: float = 0.01
    """Adaptive learning rate: halve it above 2x this KL, grow it 1.5x below half of it."""
    min_lr: float = 1e-5
    """Lower bound of the adaptive learning rate."""
    max_lr: float = 1e-2
    """Upper bound of the adaptive learning rate."""
    init_log_std: float = 0.0
    """Initial log standard deviation of the Gaussian head (actions are normalised to [-1, 1])."""
    obs_min_std: float = static(0.0)
    """Floor of the observation normaliser's scale, in each input's units (m, m/s, rad/s, s,
    or 1 for a flag); 0 (the default) is no floor. With a floor f, an input whose training
    spread is below f is divided by f instead, so a flag constant in training that flips at
    test time moves by at most 1/f rather than hitting the clip of 10. Off by default because
    it slows learning: it also shrinks inputs with a genuine small spread (the base's lateral
    velocity, std 0.24 m/s). Measured on the quick profile's training (reactive, 0.5 M steps,
    one seed, 200 episodes at 1.8 m/s): gt_rl 1.000 without a floor against 0.130 at f = 0.5
    (reading `always`), 0.430 against 0.000 (reading `when_predicted`). The default GT-Pred
    reading, `when_predicted`, is what keeps SP+FP's flag within its training range."""

    @property
    def batch_size(self) -> int:
        return self.num_envs * self.num_steps

    @property
    def minibatch_size(self) -> int:
        return self.batch_size // self.num_minibatches


def validate_ppo(cfg: PPOCfg) -> PPOCfg:
    """Raise ValueError naming the field when the batch geometry or a coefficient cannot work."""

    for name, value in non_finite_fields(cfg, "ppo."):
        raise ValueError(f"{name} must be a finite number, got {value}")
    if not cfg.hidden_sizes or min(cfg.hidden_sizes) < 1:
        raise ValueError(
            f"ppo.hidden_sizes {' '.join(map(str, cfg.hidden_sizes)) or '(none)'}: "
            "give one or more layer widths >= 1, e.g. --ppo.hidden-sizes 256 256"
        )
    nonneg = {
        "ent_coef": cfg.ent_coef,
        "vf_coef": cfg.vf_coef,
    }
    positive = {
        "clip_eps": cfg.clip_eps,
        "value_clip_eps": cfg.value_clip_eps,
        "max_grad_norm": cfg.max_grad_norm,
        "desired_kl": cfg.desired_kl,
    }
    for name, value in nonneg.items():
        if value < 0:
            raise ValueError(f"ppo.{name} must be >= 0, got {value}")
    for name, value in positive.items():
        if value <= 0:
            raise ValueError(f"ppo.{name} must be positive, got {value}")
    if cfg.num_envs < 1 or cfg.num_steps < 1 or cfg.update_epochs < 1:
        raise ValueError("ppo.num_envs, ppo.num_steps and ppo.update_epochs must be >= 1")
    if cfg.num_minibatches < 1 or cfg.batch_size % cfg.num_minibatches:
        raise ValueError(
            f"ppo.num_minibatches={cfg.num_minibatches} must divide the batch "
            f"num_envs * num_steps = {cfg.batch_size}; pick a divisor of it"
        )
    if not 0 < cfg.gamma <= 1 or not 0 <= cfg.gae_lambda <= 1:
        raise ValueError("ppo.gamma must lie in (0, 1] and ppo.gae_lambda in [0, 1]")
    if cfg.learning_rate <= 0 or cfg.min_lr <= 0 or cfg.min_lr > cfg.max_lr:
        raise ValueError("ppo.learning_rate, min_lr, max_lr must be positive with min <= max")
    return cfg
