"""The periodic evaluation of a training run against its yardstick (an SB3 callback)."""

from __future__ import annotations

from collections.abc import Callable

from stable_baselines3.common.callbacks import BaseCallback

from tether_gym.evaluation.results import Result
from tether_gym.evaluation.runner import evaluate
from tether_gym.families import family
from tether_gym.seeds import EVAL_SEED
from tether_gym.training.folders import EVALUATIONS, Checkpoints, append_row
from tether_gym.training.variants import label
from tether_gym.training.yardsticks import as_agent, yardstick

Report = Callable[[dict[str, float]], None]
"""Receives each periodic evaluation's numbers (e.g. a sweep's `tune.report`)."""


class YardstickEvalCallback(BaseCallback):
    """Every `eval_freq` timesteps: the policy vs the env's `yardstick` on the same seeded
    episodes (`EVAL_SEED`).

    Logs both success rates to TensorBoard, prints a line, saves the last model and the best
    one, appends a row to the run's `evaluations.csv` and hands the numbers to `report` (after
    saving: a sweep reports `last/` as the trial's checkpoint). The numbers are the success
    rates (the yardstick's named by the family's `yardstick_column`: `oracle_success_rate` or
    `planner_success_rate`), the family's `metrics` (the heading error, or the final distance
    and maneuvers to the goal) and the return.
    """

    def __init__(self, checkpoints: Checkpoints, best: float = -1.0, report: Report | None = None):
        super().__init__()
        config = checkpoints.config
        self.checkpoints, self.best, self.report = checkpoints, best, report
        self.label = label(config)
        self.env_id, self.env_kwargs = config.env_id, config.env_kwargs
        self.episodes = config.eval_episodes
        self.freq = config.eval_freq or 2 * config.timesteps  # 0: never
        self.next_eval = self.last_eval = 0
        self.yardstick, self.baseline = yardstick(config)
        self.family = family(self.env_id)
        self.yardstick_rate = float("nan")

    def _evaluate(self, name: str, agent: object) -> Result:
        (result,) = evaluate(
            {name: agent}, self.env_kwargs, self.episodes, EVAL_SEED, env_id=self.env_id
        )
        return result

    def _on_training_start(self) -> None:
        self.yardstick_rate = self._evaluate(self.yardstick, self.baseline).success_rate
        self.next_eval = self.num_timesteps + self.freq

    def _on_step(self) -> bool:
        if self.num_timesteps >= self.next_eval:
            self.next_eval += self.freq
            self.run_eval()
        return True

    def run_eval(self) -> None:
        self.last_eval = self.num_timesteps
        policy = self._evaluate(self.label, as_agent(self.model, self.checkpoints.config))
        numbers = {"timesteps": self.num_timesteps, "success_rate": policy.success_rate}
        numbers[self.family.yardstick_column] = self.yardstick_rate
        numbers.update({name: getattr(policy, name) for name in self.family.metrics})
        numbers["reward_mean"] = policy.reward_mean
        for key, value in numbers.items():
            if key != "timesteps":
                self.logger.record(f"eval/{key}", value)
        append_row(self.checkpoints.run_dir / EVALUATIONS, numbers)
        self.checkpoints.save(self.model, "last")
        improved = policy.success_rate > self.best
        if improved:
            self.best = policy.success_rate
            self.checkpoints.save(self.model, "best", eval_success_rate=self.best)
        print(
            f"[eval] {self.num_timesteps:,} timesteps: {self.label} "
            f"{100 * policy.success_rate:.1f}% "
            f"vs {self.yardstick} {100 * self.yardstick_rate:.1f}% success"
            + (" (new best)" if improved else ""),
            flush=True,
        )
        if self.report is not None:
            self.report(numbers)
