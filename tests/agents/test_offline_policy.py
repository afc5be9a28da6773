"""An offline run's policy file (`tether_gym.agents.offline_policy`) as an `--agents` entry: the
registry plays a `.pt` through it in the control mode its file records, refuses in one line a
`.pt` that is not one, and imports no torch until it plays one."""

from __future__ import annotations

import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest

from tests.helpers import ROOT
from tether_gym.agents.registry import make_agent, played_kwargs

ENV = "TetherNavigate_PostsReach-v3"
AIM = {"control": "aim", "coast": True}


def test_the_registry_imports_no_torch():
    code = "import sys, tether_gym.agents.registry; print('torch' in sys.modules)"
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                          check=True)  # fmt: skip
    assert done.stdout.split() == ["False"], done.stdout


def test_a_saved_policy_plays_in_its_datasets_control_mode(tmp_path):
    """A policy saved for aim control plays in it whatever the evaluation's env arguments, and
    its deterministic actions are the saved network's."""
    pytest.importorskip("torch")
    import torch

    from tether_gym.agents.offline_policy import Policy, policy_inputs, save_policy

    env = gym.make(ENV, **AIM)
    obs, _ = env.reset(seed=0)
    inputs = policy_inputs(obs)
    torch.manual_seed(0)
    policy = Policy(np.zeros(len(inputs)), np.ones(len(inputs)), env.action_space.shape[0], [8])
    facts = {"algo": "gcbc", "dataset_id": "tether_gym/PostsReach-v3/expert-aim-v0",
             "env_id": ENV, "env_kwargs": AIM}  # fmt: skip
    path = tmp_path / "policy.pt"
    save_policy(policy, path, facts)

    agent = make_agent(str(path), {"control": "setup"}, env_id=ENV)
    assert played_kwargs(agent, {"control": "setup"}) == AIM
    action, _ = agent.predict(obs)
    with torch.no_grad():
        expected = policy(torch.as_tensor(inputs)[None])[0].numpy()
    np.testing.assert_array_equal(action, expected)
    assert env.action_space.contains(action)


@pytest.mark.parametrize("content", [b"", b"not a torch file", "pretrained"])
def test_a_pt_file_that_is_not_an_offline_policy_is_refused_naming_it(tmp_path, content):
    """An empty file, another file and an SB3 policy's `.pt` (the pretrained catalog's, which
    it loads by name)."""
    pytest.importorskip("torch")
    from tether_gym.agents.pretrained import agent_file

    path = tmp_path / "policy.pt"
    if content == "pretrained":
        path.write_bytes(agent_file("pretrained-reach", ".pt").read_bytes())
    else:
        path.write_bytes(content)
    with pytest.raises(ValueError) as error:
        make_agent(str(path), {}, env_id=ENV)
    assert str(error.value) == (
        f"policy path {str(path)!r} is not the policy.pt of an offline run "
        "(tether-train --algo gcbc|iql)"
    )
    with pytest.raises(ValueError, match="does not exist or is not a file"):
        make_agent(str(tmp_path / "missing.pt"), {}, env_id=ENV)
