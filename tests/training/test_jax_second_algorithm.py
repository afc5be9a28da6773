"""A second JAX algorithm from outside the package: its record (`algorithms.register_algorithm`),
its recipe, its trainer (`training.jax.trainer.JaxTrainer`) and a zoo file of its own, and
`tether-train --backend jax --algo NAME` trains, evaluates and saves it with no edit to the
package. The algorithm here is PPO's compiled stages under a recipe of its own (one epoch per
rollout): what is traced is the seam, not a new learner."""

from __future__ import annotations

import dataclasses
import json
from typing import Any, ClassVar

import pytest

from tether_gym import algorithms
from tether_gym.algorithms import JAX, JAX_EXTRA, Algorithm, register_algorithm

pytestmark = pytest.mark.jax_train

pytest.importorskip("flax")

from tether_gym.training.config import RunConfig  # noqa: E402
from tether_gym.training.jax import ppo  # noqa: E402
from tether_gym.training.jax.recipe import PPOConfig  # noqa: E402
from tether_gym.training.jax.trainer import JaxTrainer  # noqa: E402


@dataclasses.dataclass(frozen=True)
class OneEpochConfig(PPOConfig):
    """PPO's recipe with one epoch per rollout, under its own algorithm's name."""

    algo: ClassVar[str] = "onepoch"

    @classmethod
    def from_run(cls, config: RunConfig) -> OneEpochConfig:
        recipe = super().from_run(config)
        return dataclasses.replace(recipe, n_epochs=1)


TRAINER = JaxTrainer(
    recipe=OneEpochConfig.from_run, make_stages=ppo.make_stages, policy_config=ppo.policy_config
)
RECORD = Algorithm("onepoch", JAX, f"{__name__}:TRAINER", ".msgpack", "jax", JAX_EXTRA)


@pytest.fixture
def one_epoch():
    """The algorithm registered for one test, removed after."""
    register_algorithm(RECORD)
    yield RECORD
    algorithms.ALGORITHMS.remove(RECORD)
    del algorithms.BY_KEY[("onepoch", JAX)]


def test_a_second_jax_algorithm_trains_from_its_record_only(one_epoch, tmp_path, capsys):
    from tether_gym.training import train

    with pytest.raises(ValueError, match="has an algorithm onepoch already"):
        register_algorithm(one_epoch)
    assert algorithms.names(JAX) == ("ppo", "onepoch")
    conf = tmp_path / "onepoch.yml"
    conf.write_text(
        "TetherBounce-v0:\n  n_envs: 16\n  n_timesteps: 256\n  policy: MlpPolicy\n"
        "  n_steps: 8\n  batch_size: 64\n  n_epochs: 10\n  gamma: 0.0\n"
    )
    runs = tmp_path / "runs"
    argv = ["--backend", "jax", "--algo", "onepoch", "--env", "TetherBounce-v0", "--task",
            "heading", "--dynamics", "impulse", "--conf-file", str(conf), "--seeds", "2",
            "--runs-dir", str(runs), "--name", "one", "--eval-episodes", "4",
            "--no-progress-bar"]  # fmt: skip
    assert train.main(argv) == 0
    out = capsys.readouterr().out
    assert "ONEPOCH" in out
    run = runs / "one"
    assert (run / "seed0.msgpack").is_file() and (run / "seed1.msgpack").is_file()
    saved: dict[str, Any] = json.loads((run / "seed1.json").read_text())
    assert saved["recipe"]["n_epochs"] == 1  # the algorithm's own recipe, not the zoo file's 10
