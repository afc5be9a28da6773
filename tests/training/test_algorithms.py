"""The algorithm records (`tether_gym.algorithms`): every list of algorithms is read from them
(`--algo`, `--backend`, the zoo's SB3 classes, the pretrained catalog's policies, the export's
files, the JAX trainer, the offline learners and their hyperparameters), an algorithm a backend
does not train is refused naming those it does, reading the records and a zoo entry imports
neither torch nor jax, and the JAX recipe's copy of stable-baselines3's defaults is SB3's."""

from __future__ import annotations

import inspect
import subprocess
import sys
from importlib.resources import files

import pytest

from tests.helpers import ROOT
from tether_gym.algorithms import ALGORITHMS, BACKENDS, JAX, OFFLINE, SB3, algorithm, names
from tether_gym.training import zoo


def test_the_lists_of_algorithms_are_read_from_the_records():
    from tether_gym.agents import pretrained
    from tether_gym.evaluation.export import SUFFIXES
    from tether_gym.training.train import build_parser

    assert names() == ("ppo", "sac", "gcbc", "iql") and names(JAX) == ("ppo",)
    assert names(SB3) == ("ppo", "sac") and names(OFFLINE) == ("gcbc", "iql")
    assert zoo.ALGOS == {"ppo": algorithm("ppo"), "sac": algorithm("sac")}
    assert pretrained.POLICIES == zoo.ALGOS
    actions = {action.dest: action for action in build_parser()._actions}
    assert tuple(actions["algo"].choices) == names()
    assert (tuple(actions["backend"].choices), actions["backend"].default) == (BACKENDS, SB3)
    for algo in ALGORITHMS:
        assert (files("tether_gym.training") / "hyperparams" / algo.zoo_file).is_file()
        assert algo.policy_suffix in SUFFIXES
    assert [a.name for a in ALGORITHMS if a.replay_buffer] == ["sac"]


def test_an_algorithm_a_backend_does_not_train_is_refused_naming_those_it_does():
    with pytest.raises(ValueError, match="--backend jax trains ppo only, not --algo sac"):
        algorithm("sac", JAX)
    with pytest.raises(ValueError, match=r"backend must be one of \('sb3', 'jax', 'offline'\), "):
        algorithm("ppo", "tf")
    with pytest.raises(ValueError, match="--backend offline trains gcbc or iql only, not --algo "
                       "ppo"):  # fmt: skip
        algorithm("ppo", OFFLINE)
    with pytest.raises(ValueError, match="--backend sb3 trains ppo or sac only, not --algo iql"):
        algorithm("iql")
    with pytest.raises(ValueError, match="--backend jax trains ppo only"):
        zoo.default_conf("sac", JAX)
    assert zoo.default_conf("sac").name == "sac.yml"


def test_each_record_names_its_trainer():
    stable_baselines3 = pytest.importorskip("stable_baselines3")
    assert zoo.sb3_class("ppo") is stable_baselines3.PPO
    assert zoo.sb3_class("sac") is stable_baselines3.SAC
    pytest.importorskip("jax")
    pytest.importorskip("flax")
    from tether_gym.training.jax import ppo
    from tether_gym.training.jax.recipe import PPOConfig
    from tether_gym.training.jax.trainer import JaxTrainer, trainer_of

    trainer = algorithm("ppo", JAX).load_trainer()
    assert trainer is ppo.TRAINER and isinstance(trainer, JaxTrainer)
    assert trainer_of(PPOConfig()) is trainer and trainer.recipe == PPOConfig.from_run


def test_each_offline_record_names_its_learner_and_hyperparameters():
    """The offline learners are the records' trainers, each with its hyperparameters' type,
    whose defaults are its zoo file's values on every rung a dataset is made for."""
    pytest.importorskip("torch")
    from tether_gym.datasets.create import dense_ids
    from tether_gym.training import offline, offline_learners

    assert list(offline.PARAMS) == list(names(OFFLINE))
    assert algorithm("gcbc", OFFLINE).load_trainer() is offline_learners.GCBC
    assert algorithm("iql", OFFLINE).load_trainer() is offline_learners.IQL
    for name, kind in offline.PARAMS.items():
        for env_id in dense_ids():
            entry = zoo.load_hyperparams(zoo.default_conf(name, OFFLINE), env_id=env_id)
            assert offline.learner_params(name, entry) == kind(), (name, env_id)


def test_a_zoo_expression_read_by_name_imports_nothing():
    kwargs = zoo.algo_kwargs(
        {
            "learning_rate": "lin_1e-3",
            "replay_buffer_class": "HerReplayBuffer",
            "policy_kwargs": "dict(activation_fn=nn.ReLU, "
            "features_extractor_class=NavigateExtractor, net_arch=[16])",
        },
        by_name=True,
    )
    policy = kwargs["policy_kwargs"]
    assert kwargs["learning_rate"] == "lin_1e-3"  # as written: the trainer reads it
    assert kwargs["replay_buffer_class"] == "HerReplayBuffer"
    assert policy["activation_fn"].__name__ == "ReLU" and policy["net_arch"] == [16]
    assert policy["features_extractor_class"].__name__ == "NavigateExtractor"
    with pytest.raises(ValueError, match="bad hyperparameter value for replay_buffer_class"):
        zoo.algo_kwargs({"replay_buffer_class": "DictReplayBuffer"}, by_name=True)


def test_the_records_and_the_recipes_import_neither_torch_nor_jax():
    """What `tether-train` reads before it knows its backend: the records, the run config, the
    zoo (an entry read by name), the recipe resolution, the offline run's checks and the JAX
    package's root."""
    modules = ["torch", "stable_baselines3", "jax"]
    code = (
        "import sys\n"
        "import tether_gym.algorithms, tether_gym.training.config, tether_gym.training.jax\n"
        "from tether_gym.training import folders, offline, recipe, yardsticks, zoo\n"
        "entry = zoo.load_hyperparams(zoo.DEFAULT_CONF)\n"
        "zoo.algo_kwargs(entry, by_name=True)\n"
        f"print(*(name in sys.modules for name in {modules!r}))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                          check=True)  # fmt: skip
    assert done.stdout.split() == ["False"] * len(modules), done.stdout


def test_the_jax_recipe_defaults_are_stable_baselines3s():
    """`recipe.PPO_DEFAULTS` and `POLICY_DEFAULTS` stand for SB3's (the JAX path reads no SB3):
    the defaults of the signatures of `PPO` and `ActorCriticPolicy`."""
    pytest.importorskip("stable_baselines3")
    pytest.importorskip("flax")
    from stable_baselines3 import PPO
    from stable_baselines3.common.policies import ActorCriticPolicy

    from tether_gym.training.jax.recipe import (
        POLICY_DEFAULTS,
        PPO_DEFAULTS,
        SUPPORTED_KWARGS,
        PPOConfig,
    )

    def defaults(function) -> dict:
        parameters = inspect.signature(function).parameters.items()
        return {name: p.default for name, p in parameters if p.default is not p.empty}

    assert PPO_DEFAULTS == {name: defaults(PPO.__init__)[name] for name in PPO_DEFAULTS}
    assert set(PPO_DEFAULTS) == SUPPORTED_KWARGS - {"policy_kwargs"}
    policy = defaults(ActorCriticPolicy.__init__)
    assert POLICY_DEFAULTS == {**{name: policy[name] for name in POLICY_DEFAULTS},
                               "activation_fn": policy["activation_fn"].__name__}  # fmt: skip
    # an entry that gives nothing trains with SB3's PPO as it is
    config = PPOConfig.from_params("TetherBounce-v0", {"n_timesteps": 2048, "n_envs": 1})
    assert (config.n_steps, config.batch_size, config.learning_rate, config.linear_lr) == (
        2048, 64, 3e-4, False)  # fmt: skip
    assert (config.pi_arch, config.vf_arch, config.activation, config.log_std_init) == (
        (64, 64), (64, 64), "tanh", 0.0)  # fmt: skip
