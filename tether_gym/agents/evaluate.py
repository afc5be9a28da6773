"""Deprecated: the evaluation lives in `tether_gym.evaluation`; this module re-exports its
public names from their new homes, and `python -m tether_gym.agents.evaluate` still runs
`tether-evaluate`.

- `evaluate`, `run_bounce`, `run_navigation`, `BATCH`: `tether_gym.evaluation.runner`;
- `EvalResult`, `NavigationResult`, `SUMMARY_FIELDS`, `NAVIGATION_FIELDS`:
  `tether_gym.evaluation.results`;
- `wilson_interval`, `paired`: `tether_gym.evaluation.statistics`;
- `format_table`, `paired_table`, `plot`: `tether_gym.evaluation.reports`;
- `build_parser`, `main`, `agent_names`, `model_name`, `CHECKPOINTS`:
  `tether_gym.evaluation.cli`;
- `make_agent`, `agent_choices`, `action_size`, `looks_like_path`:
  `tether_gym.agents.registry`;
- `load_agent`: `tether_gym.agents.saved`.
"""

from tether_gym.agents.registry import action_size, agent_choices, looks_like_path, make_agent
from tether_gym.agents.saved import load_agent
from tether_gym.evaluation.cli import CHECKPOINTS, agent_names, build_parser, main, model_name
from tether_gym.evaluation.reports import format_table, paired_table, plot
from tether_gym.evaluation.results import (
    NAVIGATION_FIELDS,
    SUMMARY_FIELDS,
    EvalResult,
    NavigationResult,
)
from tether_gym.evaluation.runner import BATCH, evaluate, run_bounce, run_navigation
from tether_gym.evaluation.statistics import paired, wilson_interval

__all__ = [
    "BATCH", "CHECKPOINTS", "NAVIGATION_FIELDS", "SUMMARY_FIELDS", "EvalResult",
    "NavigationResult", "action_size", "agent_choices", "agent_names", "build_parser",
    "evaluate", "format_table", "load_agent", "looks_like_path", "main", "make_agent",
    "model_name", "paired", "paired_table", "plot", "run_bounce", "run_navigation",
    "wilson_interval",
]  # fmt: skip

if __name__ == "__main__":
    main()
