"""PPO over the greedy planner's proposals (tether_gym.training.proposals): what the policy
sees and plays, and the settings a run refuses (tests/training/test_navigate.py trains one)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import torch
from stable_baselines3.common.torch_layers import CombinedExtractor

from tests.helpers.envs import vector_env
from tether_gym.agents import planned
from tether_gym.agents.networks import NavigateExtractor, ProposalPolicy
from tether_gym.agents.planned import PROPOSALS_KEY
from tether_gym.agents.planners import KINDS, GreedyPlanner, observed_states
from tether_gym.training import proposals, train
from tether_gym.training.sb3 import make_sb3_vec_env

KWARGS = {"n_obstacles": 3, "dynamics": "impulse", "max_maneuvers": 2, "task": "stop"}
COST = 3  # the features' column of the cost over COST_CAP
KIND = slice(5, 5 + len(KINDS))


def native_env(n: int, seed: int, **kwargs):
    env = vector_env(
        "TetherNavigate-v3",
        n,
        **(kwargs or KWARGS),
    )
    return env, env.reset(seed=seed)[0]


def test_the_proposals_are_the_best_of_distinct_groups_in_rank_order():
    planner = GreedyPlanner(KWARGS)
    _, obs = native_env(16, seed=3)
    k = 8
    features, actions = planned.propose(planner, obs, k)
    features = features.reshape(16, k, planned.PROPOSAL_FEATURES)
    candidates, all_actions, _, cost, _ = planner.expand(observed_states(obs, planner.config), 0)
    for i in range(16):
        present = features[i, :, 0] == 1
        assert present[0] and np.all(present[:-1] >= present[1:]), "present slots come first"
        shown = features[i, present, COST]
        assert np.all(np.diff(shown) >= 0), "slots are in rank order"
        least = min(cost[candidates.rows == i].min(), planned.COST_CAP)
        assert shown[0] == pytest.approx(least / planned.COST_CAP, rel=1e-6)
        # one proposal per (peg, kind): the bearing names the peg, the one-hot the kind
        pegs = np.round(actions[i, present, 0], 4).tolist()
        kinds = np.argmax(features[i, present][:, KIND], axis=1).tolist()
        assert len(set(zip(pegs, kinds, strict=True))) == present.sum()
        np.testing.assert_array_equal(
            actions[i, ~present], np.repeat(actions[i, :1], (~present).sum(), 0)
        )
        mine = all_actions[candidates.rows == i]
        assert all(np.any(np.all(mine == a, axis=1)) for a in actions[i, present])
    # a predicted failure shows the capped cost, and nothing else does
    np.testing.assert_array_equal(features[..., 2] == 1, features[..., COST] == 1)


def test_the_vec_env_plays_the_picked_proposal_and_the_agent_plays_the_same():
    planner = GreedyPlanner(KWARGS)
    k = 4
    env = proposals.ProposalVecEnv(
        make_sb3_vec_env(4, seed=7, env_id="TetherNavigate-v3", **KWARGS), planner, k
    )
    assert env.action_space == gym.spaces.Discrete(k)
    native, ref = native_env(4, seed=7)
    obs = env.reset()
    truncated = 0
    for step in range(8):
        pick = np.array([step % k, 0, k - 1, 1])
        features, actions = planned.propose(planner, ref, k)
        np.testing.assert_array_equal(obs[PROPOSALS_KEY], features)
        obs, rewards, dones, infos = env.step(pick)
        ref, ref_rewards, _, _, _ = native.step(actions[np.arange(4), pick])
        np.testing.assert_allclose(rewards, ref_rewards.astype(np.float32))
        for i in np.flatnonzero(dones):
            final = infos[i]["terminal_observation"]
            if infos[i]["TimeLimit.truncated"]:
                batch = {key: value[None] for key, value in final.items() if key != PROPOSALS_KEY}
                expected = planned.propose(planner, batch, k)[0][0]
                truncated += 1
            else:
                expected = np.zeros(k * planned.PROPOSAL_FEATURES)
            np.testing.assert_array_equal(final[PROPOSALS_KEY], expected)
    assert truncated > 0, "a truncated episode's terminal observation must be checked"

    class Third:
        def predict(self, obs, state=None, episode_start=None, deterministic=True):
            return np.full(len(obs[PROPOSALS_KEY]), 2), state

    agent = planned.ProposalAgent(Third(), planner, k)
    _, actions = planned.propose(planner, ref, k)
    np.testing.assert_array_equal(agent.predict(ref)[0], actions[:, 2])
    single = {key: value[1] for key, value in ref.items()}
    np.testing.assert_array_equal(agent.predict(single)[0], actions[1, 2])


@pytest.mark.parametrize(
    ("env", "extra", "message"),
    [(["--algo", "sac", "--env", "TetherNavigateSparse-v3"], [], "PPO on TetherNavigate only"),
     (["--env", "TetherBounce-v0"], [], "PPO on TetherNavigate only"),
     (["--env", "TetherNavigate-v3"], ["proposals_k:1"], "proposals_k must be an"),
     (["--env", "TetherNavigate-v3"], ["residual:greedy"], "not with residual"),
     (["--env", "TetherNavigate-v3"], ["proposals:lookahead"], "must be 'greedy'")],
)  # fmt: skip
def test_bad_proposal_settings_name_themselves(tmp_path, capsys, env, extra, message):
    with pytest.raises(SystemExit):
        train.main([*env, "--runs-dir", str(tmp_path), "--hyperparams", "proposals:greedy", *extra])
    assert message in capsys.readouterr().err


def test_depth_two_shows_the_best_next_maneuver_of_each_proposal():
    reach = {"n_obstacles": 3, "dynamics": "impulse"}
    planner = GreedyPlanner(reach)
    _, obs = native_env(6, seed=11, **reach)
    k = 4
    shallow, _ = planned.propose(planner, obs, k, depth=1)
    deep, actions = planned.propose(planner, obs, k, depth=2)
    shallow, deep = (f.reshape(6, k, planned.PROPOSAL_FEATURES) for f in (shallow, deep))
    np.testing.assert_array_equal(deep[..., :-2], shallow[..., :-2])
    assert not shallow[..., -2:].any()
    states = observed_states(obs, planner.config)
    successes = 0
    for i in range(6):
        for j in np.flatnonzero(deep[i, :, 0]):
            after, _, _ = planner.kernel.step(states[i : i + 1], actions[i, j][None])
            if deep[i, j, 1] or deep[i, j, 2]:  # the episode ends: no next maneuver
                continue
            _, _, _, cost, _ = planner.expand(after, 1)
            least = min(cost.min(), planned.COST_CAP)
            assert deep[i, j, -2] == pytest.approx(least / planned.COST_CAP, rel=1e-6)
            assert deep[i, j, -1] == (cost.min() < 2.0)
            successes += deep[i, j, -1]
    assert successes > 0, "some proposal must be followed by a predicted success"
    with pytest.raises(ValueError, match="proposals_depth must be 1 or 2"):
        planned.ProposalAgent(None, planner, k, 3)


def scorer_policy(k: int = 4, **policy_kwargs):
    """A `ProposalPolicy` on a proposals env's spaces, and the env's first observations."""
    planner = GreedyPlanner(KWARGS)
    env = proposals.ProposalVecEnv(
        make_sb3_vec_env(2, seed=5, env_id="TetherNavigate-v3", **KWARGS), planner, k
    )
    policy = ProposalPolicy(
        env.observation_space, env.action_space, lambda _: 1e-3, **policy_kwargs
    )
    return policy, env.reset()


@pytest.mark.parametrize("extractor", [CombinedExtractor, NavigateExtractor])
def test_the_scorer_scores_each_slot_alike_and_never_an_empty_one(extractor):
    k = 4
    policy, obs = scorer_policy(
        k, net_arch=dict(pi=[32], vf=[32]), features_extractor_class=extractor
    )
    for layer in policy.mlp_extractor.score:  # away from the near-equal start
        if isinstance(layer, torch.nn.Linear):
            torch.nn.init.normal_(layer.weight)
    slots = obs[PROPOSALS_KEY].reshape(2, k, planned.PROPOSAL_FEATURES)
    slots[:, :, 0] = 1.0  # all present, and slot 1 unlike slot 2
    slots[:, 1, 3:] += 0.5
    order = [2, 0, 3, 1]

    def logits(proposal_slots):
        batch = {**obs, PROPOSALS_KEY: proposal_slots.reshape(2, -1)}
        tensors, _ = policy.obs_to_tensor(batch)
        with torch.no_grad():
            return policy.get_distribution(tensors).distribution.logits.numpy()

    scores = logits(slots)
    assert np.ptp(scores, axis=1).min() > 1e-3, "the slots must score apart"
    # a proposal scores by what it is, not by its slot: permuting the slots permutes the scores
    np.testing.assert_allclose(logits(slots[:, order]), scores[:, order], rtol=1e-5, atol=1e-5)
    slots[:, 1, 0] = 0.0
    empty = logits(slots)
    assert np.all(empty[:, 1] < -50), "an empty slot is never picked"
    assert np.all(np.isfinite(empty))


class ProposalsFirst(CombinedExtractor):
    """The dict's entries in reverse order: the proposals first."""

    def forward(self, observations):
        flat = [observations[key].flatten(1) for key in sorted(observations, reverse=True)]
        return torch.cat(flat, dim=1)


def test_the_scorer_reads_net_arch_as_sb3_does_and_refuses_another_layout():
    policy, _ = scorer_policy(net_arch=[16])  # a list: both networks
    widths = [m.out_features for m in policy.mlp_extractor.value if isinstance(m, torch.nn.Linear)]
    assert widths == [16] and policy.mlp_extractor.latent_dim_vf == 16
    policy, _ = scorer_policy(net_arch=dict(pi=[8]))  # no "vf": the value net is linear
    assert policy.mlp_extractor.latent_dim_vf == policy.features_dim
    with pytest.raises(ValueError, match="must end its features with the 'proposals' entry"):
        scorer_policy(features_extractor_class=ProposalsFirst)


@pytest.mark.parametrize(
    ("extra", "message"),
    [([], "policy ProposalPolicy scores a planner's proposals"),
     (["proposals:greedy", "normalize:true"], "not with normalize")],
)  # fmt: skip
def test_the_scorer_policy_needs_proposals_unnormalized(tmp_path, capsys, extra, message):
    # a short run, so that a missing check fails the test rather than trains for long
    argv = ["--env", "TetherNavigate-v3", "--runs-dir", str(tmp_path), "--timesteps", "64",
            "--n-envs", "2", "--eval-freq", "0", "--eval-episodes", "2"]  # fmt: skip
    with pytest.raises(SystemExit):
        train.main([*argv, "--hyperparams", "policy:ProposalPolicy", *extra])
    assert message in capsys.readouterr().err
