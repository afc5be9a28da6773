"""The docs' `tether-evaluate` commands name agents of the env they play, in every block: also
in those the docs' tests do not run (`<!-- not run: ... -->`, a JAX run that compiles for
minutes), where a wrong pairing would reach a reader untested."""

from __future__ import annotations

import gymnasium as gym
import pytest

from tests.helpers import ROOT
from tests.helpers.docblocks import blocks, commands
from tether_gym.arguments import DEFAULT_ENV_ID
from tether_gym.evaluation import cli as evaluate
from tether_gym.families import FAMILIES, family

PAGES = sorted(p for p in (ROOT / "docs").rglob("*.md") if "figures" not in p.parts)
EVALUATIONS = [
    (block, words[1:])
    for page in [*PAGES, ROOT / "README.md"]
    for block in blocks(page)
    if block.language == "bash"
    for words in commands(block.code)
    if words[0] == "tether-evaluate"
]


def played_env(argv: list[str]) -> str:
    """The env a `tether-evaluate` command plays: its `--env`, else a saved model's, which its
    run folder's default name carries (`recipe.default_name`: the env id unless the default)."""
    args = evaluate.build_parser().parse_known_args(argv)[0]
    if args.env:
        return args.env
    ids = [i for f in FAMILIES for i in f.ids if i != DEFAULT_ENV_ID]
    for spec in args.agents or []:
        if evaluate.is_saved(spec):
            return next((i for i in ids if i in spec), DEFAULT_ENV_ID)
    return DEFAULT_ENV_ID


def test_the_docs_have_tether_evaluate_commands_in_blocks_not_run():
    assert EVALUATIONS and any(block.not_run for block, _ in EVALUATIONS)


@pytest.mark.parametrize(
    "block, argv", EVALUATIONS, ids=[f"{b.id}:{' '.join(a)[:40]}" for b, a in EVALUATIONS]
)
def test_a_tether_evaluate_command_names_agents_of_its_env(block, argv):
    env_id = played_env(argv)
    gym.spec(env_id)
    args = evaluate.build_parser().parse_known_args(argv)[0]
    named = [spec for spec in args.agents or [] if not evaluate.is_saved(spec)]
    agents = family(env_id).agents
    wrong = [name for name in named if name not in agents]
    assert not wrong, f"{block.id}: {wrong} on {env_id}, which takes {sorted(agents)}"


@pytest.mark.slow
def test_the_jax_quick_start_prints_its_result_and_no_warning():
    """docs/jax.md's quick start (not run with the docs' blocks: it compiles the JAX step),
    in a fresh interpreter with every warning shown: its line, and nothing from Gymnasium's
    checkers (a jax env's observations are jax arrays, which `gym.make`'s passive checker warns
    of unless it is off)."""
    import subprocess
    import sys

    pytest.importorskip("jax")
    (block,) = [b for b in blocks(ROOT / "docs" / "jax.md")
                if b.language == "python" and "TetherBounce-jax-v0" in b.code]  # fmt: skip
    done = subprocess.run(
        [sys.executable, "-W", "default", "-c", block.code], cwd=ROOT, capture_output=True,
        text=True, timeout=600,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() and "WARN" not in done.stderr, done.stderr
