"""PPO compiled with the JAX envs: rollout, advantages and updates inside one `jit`, seeds under
`jax.vmap`, in the PureJaxRL design (flax.linen networks, optax's Adam), with the semantics of
stable-baselines3's `PPO` where they change what is learned.

    from tether_gym.training.jax.ppo import make_train
    from tether_gym.training.jax.recipe import PPOConfig
    config = PPOConfig.from_zoo("TetherBounce-v0", timesteps=200_000)
    train = jax.jit(jax.vmap(make_train(config)))  # one compiled run of every seed
    out = train(jax.random.split(jax.random.key(0), 5))  # out["params"]: a stack of 5 policies

The recipe is the SB3 run's (`tether_gym.training.jax.recipe`). What is SB3's here:

- the networks: separate pi and vf MLPs (`net_arch=dict(pi=..., vf=...)`, a list: both), the
  activation, orthogonal initialization (gain sqrt(2) in the hidden layers, 0.01 for the action
  mean, 1 for the value; zero biases), a state-independent log std (`log_std_init`); on
  TetherNavigate, `NavigateExtractor`'s features and `AimPolicy`'s start at the goal
  (`tether_gym.agents.jax_policy` mirrors them);
- the Gaussian's sample is stored and its log-prob taken unclipped; the env gets it clipped to
  the action space's bounds; the deterministic action is the mean, clipped;
- GAE over the rollout, bootstrapped from the value of the observation after it; a truncated
  episode's last reward plus gamma times the value of its last observation (SB3's time-limit
  bootstrap); the observation as SB3 sees it (float32, no normalization; a goal dict's entries
  as the plain row they were cut from);
- per epoch, a fresh permutation of the rollout cut into `batch_size` minibatches; the advantage
  normalized per minibatch (torch's unbiased std, + 1e-8); the clipped surrogate, the value loss
  `mean((return - value)^2)` (clipped around the old value only with `clip_range_vf`), the
  entropy term, the global gradient norm clipped to `max_grad_norm`, Adam with eps 1e-5;
- `target_kl`: as SB3, a minibatch whose approximate KL (`mean((r - 1) - log r)` at the
  parameters before its step) exceeds 1.5 * target_kl is not applied and ends the epochs of
  that rollout (a `lax.while_loop`; under `vmap` every seed stops at its own minibatch, the loop
  runs until the last seed stops);
- the learning rate `lin_<x>`: x times the progress remaining after the rollout (SB3's
  `LinearSchedule`), updates until the timesteps are reached (the last rollout may overshoot).

`make_learner` is the update of one rollout; `tests/training/test_jax_ppo_matches_sb3.py` holds
it to SB3's `PPO.train` on the same rollout, weights and minibatches.

What differs: the rollout runs the JAX kernel (`tether_gym.jax`, gymnax convention), float32;
`batch_size` must divide `n_steps * n_envs` (SB3 allows a short last minibatch); the random
streams are JAX's.

`TRAINER` is PPO's `JaxTrainer` (the `tether_gym.algorithms` record of ppo on jax names it):
`tether_gym.training.jax.trainer.train_seeds` trains its seeds in chunks, and its policy plays as
an agent (`tether_gym.agents.jax_policy.JaxPolicyAgent`: SB3's `predict(obs,
deterministic=True)` on numpy observations) from the .msgpack and .json that `save_trained`
writes (`policy_config`: the format is described in `tether_gym.agents.jax_policy`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import optax
from jax import lax

from tether_gym.agents.jax_policy import ActorCritic, PolicyConfig
from tether_gym.families import config_arguments, load
from tether_gym.training.jax import gymnax_entry_point
from tether_gym.training.jax.recipe import PPOConfig
from tether_gym.training.jax.trainer import JaxTrainer


def network(config: PPOConfig, action_dim: int) -> ActorCritic:
    return ActorCritic(
        action_dim=action_dim,
        pi_arch=config.pi_arch,
        vf_arch=config.vf_arch,
        activation=config.activation,
        log_std_init=config.log_std_init,
        ortho_init=config.ortho_init,
        extractor=config.extractor,
        aim_control=config.aim_control,
        start_speed=config.start_speed,
    )


def gaussian_log_prob(x: jax.Array, mean: jax.Array, log_std: jax.Array) -> jax.Array:
    """The log density of a diagonal Gaussian, summed over the action's entries."""
    z = (x - mean) * jnp.exp(-log_std)
    return jnp.sum(-0.5 * z * z - log_std - 0.5 * math.log(2 * math.pi), axis=-1)


def gaussian_entropy(log_std: jax.Array) -> jax.Array:
    return jnp.sum(log_std + 0.5 + 0.5 * math.log(2 * math.pi), axis=-1)


def make_env(config: PPOConfig):
    """The gymnax-convention JAX env of the recipe (its id's arguments, `env_kwargs` over
    them), and its params."""
    env_class = load(gymnax_entry_point(config.env_id))
    env = env_class(**config_arguments(config.env_id, config.env_kwargs))
    return env, env.default_params


class Transition(NamedTuple):
    obs: jax.Array
    action: jax.Array
    log_prob: jax.Array
    value: jax.Array
    reward: jax.Array
    done: jax.Array
    success: jax.Array


class RunnerState(NamedTuple):
    params: Any
    opt_state: Any
    env_state: Any
    obs: jax.Array
    key: jax.Array


METRICS = (
    "reward", "success", "policy_loss", "value_loss", "entropy", "approx_kl", "clip_fraction",
    "minibatches", "learning_rate",
)  # fmt: skip
"""Per update (a vector over updates, per seed): the rollout's mean reward, the success rate
of the episodes that ended in it, and the applied minibatches' mean losses, KL and clip
fraction, their count and the rate."""


def optimizer(config: PPOConfig) -> optax.GradientTransformation:
    """SB3's: the global gradient norm clipped to `max_grad_norm`, then Adam with eps 1e-5 (the
    learning rate is applied by the caller, per rollout)."""
    clip = optax.clip_by_global_norm(config.max_grad_norm)
    return optax.chain(clip, optax.scale_by_adam(eps=1e-5))


Learner = Callable[..., tuple[Any, Any, jax.Array]]
"""`learn(params, opt_state, flat, adv, returns, perms, lr)` -> (params, opt_state, sums)."""


def make_learner(config: PPOConfig, net: ActorCritic) -> Learner:
    """SB3's `PPO.train` on one rollout, as a jittable function: `learn(params, opt_state, flat,
    adv, returns, perms, lr)`, where `flat` is the rollout's `Transition` flattened to
    (`rollout_size`, ...), `adv` and `returns` its advantages and returns, `perms` the
    (`n_epochs`, `rollout_size`) permutations that cut each epoch into `batch_size`
    minibatches, `lr` the rollout's learning rate. Each minibatch is one gradient step of the
    clipped surrogate (advantages normalized per minibatch), the value loss and the entropy
    term, unless its approximate KL at the parameters before the step exceeds 1.5 *
    `target_kl`: then it is not applied and the epochs end. Returns the parameters, the
    optimizer state and `sums`: the applied minibatches' sums of (policy loss, value loss,
    entropy, approximate KL, clip fraction) and their count."""
    tx = optimizer(config)
    n_mb, total_mb = config.n_minibatches, config.n_epochs * config.n_minibatches
    kl_limit = jnp.inf if config.target_kl is None else 1.5 * config.target_kl

    def loss_fn(params, batch: Transition, adv, returns, clip_range):
        mean, log_std, value = net.apply(params, batch.obs)
        log_prob = gaussian_log_prob(batch.action, mean, log_std)
        if config.normalize_advantage and adv.shape[0] > 1:
            adv = (adv - adv.mean()) / (jnp.std(adv, ddof=1) + 1e-8)
        log_ratio = log_prob - batch.log_prob
        ratio = jnp.exp(log_ratio)
        surrogate = jnp.minimum(
            adv * ratio, adv * jnp.clip(ratio, 1.0 - clip_range, 1.0 + clip_range)
        )
        policy_loss = -surrogate.mean()
        if config.clip_range_vf is not None:
            value = batch.value + jnp.clip(
                value - batch.value, -config.clip_range_vf, config.clip_range_vf
            )
        value_loss = jnp.mean((returns - value) ** 2)
        entropy = gaussian_entropy(log_std)
        loss = policy_loss - config.ent_coef * entropy + config.vf_coef * value_loss
        approx_kl = lax.stop_gradient(jnp.mean((ratio - 1.0) - log_ratio))
        clip_fraction = jnp.mean((jnp.abs(ratio - 1.0) > clip_range).astype(jnp.float32))
        return loss, (policy_loss, value_loss, entropy, approx_kl, clip_fraction)

    grad_fn = jax.value_and_grad(loss_fn, has_aux=True)

    def learn(params, opt_state, flat: Transition, adv, returns, perms, lr):
        def cond(carry):
            _, _, i, going, _ = carry
            return jnp.logical_and(going, i < total_mb)

        def body(carry):
            params, opt_state, i, going, sums = carry
            idx = lax.dynamic_slice(perms[i // n_mb], ((i % n_mb) * config.batch_size,),
                                    (config.batch_size,))  # fmt: skip
            batch = jax.tree.map(lambda x: x[idx], flat)
            (_, aux), grads = grad_fn(params, batch, adv[idx], returns[idx], config.clip_range)
            going = aux[3] <= kl_limit
            updates, new_opt = tx.update(grads, opt_state, params)
            new_params = jax.tree.map(lambda p, g: p - lr * g, params, updates)
            params, opt_state = jax.tree.map(
                lambda a, b: jnp.where(going, a, b), (new_params, new_opt), (params, opt_state)
            )
            sums = sums + jnp.where(going, jnp.stack([*aux, 1.0]), 0.0)
            return params, opt_state, i + 1, going, sums

        params, opt_state, _, _, sums = lax.while_loop(
            cond, body, (params, opt_state, 0, jnp.bool_(True), jnp.zeros(6))
        )
        return params, opt_state, sums

    return learn


def make_train(config: PPOConfig) -> Callable[[jax.Array], dict[str, Any]]:
    """`train(key)`: one seed's whole run, jittable and vmappable (`jax.vmap(train)(keys)`),
    returning {"params": the trained parameters, "metrics": {name: (n_updates,)}}.
    `make_stages(config)` gives the same run cut into `init` and `update` calls (progress)."""
    init, update = make_stages(config)

    def train(key: jax.Array) -> dict[str, Any]:
        state = init(key)
        state, metrics = update(state, 0, config.n_updates)
        return {"params": state.params, "metrics": metrics}

    return train


def make_stages(config: PPOConfig):
    """(`init(key)` -> RunnerState, `update(state, start, count)` -> (state, metrics)): the
    run of `make_train` in pieces; `update` runs updates start .. start + count - 1 (past
    `n_updates` it does nothing: the metrics there are NaN). `start` and `count` are static
    under `jit` (`count`) or unbatched (`start`: `vmap(update, in_axes=(0, None, None))`)."""
    env, env_params = make_env(config)
    obs_space, act_space = env.observation_space(env_params), env.action_space(env_params)
    action_dim = int(np.prod(act_space.shape))
    low, high = jnp.asarray(act_space.low), jnp.asarray(act_space.high)
    net = network(config, action_dim)
    tx = optimizer(config)
    learn = make_learner(config, net)
    n_envs, n_steps = config.n_envs, config.n_steps
    func = env.func_env
    vreset = jax.vmap(env.reset_env, in_axes=(0, None))
    column = func.kernel.outcome.index
    success_column = column.get("is_success")

    def init(key: jax.Array) -> RunnerState:
        key, k_net, k_env = jax.random.split(key, 3)
        params = net.init(k_net, jnp.zeros(obs_space.shape, jnp.float32))
        obs, env_state = vreset(jax.random.split(k_env, n_envs), env_params)
        return RunnerState(params, tx.init(params), env_state, obs, key)

    def env_step(state: RunnerState, _):
        key, k_act, k_step = jax.random.split(state.key, 3)
        mean, log_std, value = net.apply(state.params, state.obs)
        action = mean + jnp.exp(log_std) * jax.random.normal(k_act, mean.shape)
        log_prob = gaussian_log_prob(action, mean, log_std)
        # the step and the finished episodes' next ones, in one call (one numba call on a CPU)
        env_state, obs, final_obs, outcome = func.step_autoreset_batch(
            state.env_state, jnp.clip(action, low, high), k_step, env_params
        )
        reward, truncated = outcome[:, column["reward"]], outcome[:, column["truncated"]] != 0.0
        done = (outcome[:, column["terminated"]] != 0.0) | truncated
        if config.gamma > 0.0:  # SB3: a truncated episode's last reward + gamma V(its last obs)
            _, _, last_value = net.apply(state.params, final_obs)
            reward = reward + config.gamma * last_value * truncated
        success = jnp.zeros_like(reward) if success_column is None else outcome[:, success_column]
        transition = Transition(
            state.obs, action, log_prob, value, reward.astype(jnp.float32),
            done.astype(jnp.float32), success.astype(jnp.float32),
        )  # fmt: skip
        return state._replace(env_state=env_state, obs=obs, key=key), transition

    def advantages(traj: Transition, last_value: jax.Array) -> jax.Array:
        def backward(carry, t):
            gae, next_value = carry
            not_done = 1.0 - t.done
            delta = t.reward + config.gamma * next_value * not_done - t.value
            gae = delta + config.gamma * config.gae_lambda * not_done * gae
            return (gae, t.value), gae

        _, adv = lax.scan(backward, (jnp.zeros_like(last_value), last_value), traj, reverse=True)
        return adv

    def one_update(state: RunnerState, u: jax.Array):
        state, traj = lax.scan(env_step, state, None, n_steps)
        _, _, last_value = net.apply(state.params, state.obs)
        adv = advantages(traj, last_value)
        returns = adv + traj.value
        flat = jax.tree.map(lambda x: x.reshape((config.rollout_size, *x.shape[2:])), traj)
        adv, returns = adv.reshape(-1), returns.reshape(-1)
        progress_remaining = 1.0 - (u + 1.0) * config.rollout_size / config.timesteps
        lr = config.learning_rate * (
            jnp.maximum(progress_remaining, 0.0) if config.linear_lr else 1.0
        )
        key, k_perm = jax.random.split(state.key)
        perms = jax.vmap(lambda k: jax.random.permutation(k, config.rollout_size))(
            jax.random.split(k_perm, config.n_epochs)
        )
        params, opt_state, sums = learn(state.params, state.opt_state, flat, adv, returns,
                                        perms, lr)  # fmt: skip
        count = sums[5]
        means = sums[:5] / jnp.maximum(count, 1.0)
        metrics = {
            "reward": traj.reward.mean(),
            "success": traj.success.sum() / jnp.maximum(traj.done.sum(), 1.0),
            "policy_loss": means[0],
            "value_loss": means[1],
            "entropy": means[2],
            "approx_kl": means[3],
            "clip_fraction": means[4],
            "minibatches": count,
            "learning_rate": lr,
        }
        metrics = {name: jnp.asarray(value, jnp.float32) for name, value in metrics.items()}
        return state._replace(params=params, opt_state=opt_state, key=key), metrics

    def update(state: RunnerState, start, count: int):
        def step(state, i):
            u = start + i
            nan = {name: jnp.float32(jnp.nan) for name in METRICS}
            return lax.cond(u < config.n_updates, one_update, lambda s, u: (s, nan), state, u)

        return lax.scan(step, state, jnp.arange(count))

    return init, update


def policy_config(config: PPOConfig) -> PolicyConfig:
    """What the policy trained with `config` needs to play (saved beside its parameters)."""
    env, params = make_env(config)
    obs, act = env.observation_space(params), env.action_space(params)
    return PolicyConfig(
        env_id=config.env_id,
        env_kwargs=dict(config.env_kwargs),
        pi_arch=config.pi_arch,
        vf_arch=config.vf_arch,
        activation=config.activation,
        log_std_init=config.log_std_init,
        obs_shape=tuple(obs.shape),
        obs_low=np.asarray(obs.low, dtype=float).tolist(),
        obs_high=np.asarray(obs.high, dtype=float).tolist(),
        action_shape=tuple(act.shape),
        action_low=np.asarray(act.low, dtype=float).tolist(),
        action_high=np.asarray(act.high, dtype=float).tolist(),
        recipe=config.as_dict(),
        extractor=config.extractor,
        aim_control=config.aim_control,
        start_speed=config.start_speed,
        row_keys=tuple(env.func_env.row_keys),
    )


TRAINER = JaxTrainer(
    recipe=PPOConfig.from_run, make_stages=make_stages, policy_config=policy_config
)
"""PPO on the JAX envs, as `tether_gym.training.jax.trainer` and `run` drive it."""
