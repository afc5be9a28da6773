"""One quantity, one number: where the docs show the same agent's success twice with two
numbers, the tables name what differs (the episodes and their seed, the control mode with or
without `coast`), the notes count the files they read, a header promises an interval only where
the rows show one, and `tether-evaluate` says which episodes it played."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from tests.helpers import ROOT
from tests.helpers.docblocks import blocks, commands
from tether_gym.agents import pretrained
from tether_gym.evaluation import cli as evaluate
from tether_gym.evaluation.statistics import wilson_interval

DOCS = ROOT / "docs"
if str(DOCS) not in sys.path:  # the docs' modules, as docs/hooks.py finds them
    sys.path.insert(0, str(DOCS))

from docgen import macros, readme, results, tables  # noqa: E402

LADDER = "python -m benchmarks.experiments.ladder"
PAGES = [*sorted(p for p in DOCS.rglob("*.md") if "figures" not in p.parts), ROOT / "README.md"]


def write(path: Path, rows: list[dict], setup: dict) -> None:
    """A results file (the schema) with these rows and setup."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps({
        "command": LADDER, "commit": None, "dirty": None, "environment": {}, "seconds": None,
        "setup": setup, "rows": rows, "details": {},
    }))  # fmt: skip


def random_row(rate: float) -> dict:
    return {"name": "random", "episodes": 1000, "success_rate": rate}


def test_a_ladder_table_names_coast_in_its_control_column(tmp_path):
    """Random in aim control with and without `coast`: two columns that say which, not one
    header over two numbers (nor two files for one cell)."""
    env = "TetherNavigate_PostsReach-v3"
    for name, kwargs, rate in (("a", {"control": "aim"}, 0.224),
                               ("b", {"control": "aim", "coast": True}, 0.316)):  # fmt: skip
        setup = {"env_id": env, "env_kwargs": kwargs, "seed": 2_000_000}
        write(tmp_path / f"{name}.json", [random_row(rate)], setup)
    lines = tables.ladder_table({"*.json": LADDER}, ["random"], by_control=True, root=tmp_path)
    lines = lines.splitlines()
    assert lines[0] == "| env | random, aim | random, aim + coast |"
    assert lines[2] == f"| `{env}` | 22.4% | 31.6% |"


def test_the_yardsticks_of_a_run_with_coast_say_so():
    assert results.control_label({"control": "aim", "coast": True}) == "aim + coast"
    assert results.control_label({"control": "velocity"}) == "velocity"
    assert results.control_label({}) == "setup"


def test_a_note_counts_the_files_its_globs_match(tmp_path):
    setup = {"env_id": "TetherNavigate_OpenReach-v3", "env_kwargs": {}, "seed": 0}
    for name in "abc":
        write(tmp_path / "r" / f"{name}.json", [random_row(0.5)], setup)
    note = tables.sources_line({"r/*.json": LADDER}, root=tmp_path)
    assert '??? info "Read from 3 files"' in note
    note = tables.sources_line({"r/a.json": LADDER, "r/[bc].json": "python x.py"}, root=tmp_path)
    assert '??? info "Read from 3 files, written by 2 commands"' in note
    assert '"Read from 1 file"' in tables.sources_line({"r/a.json": LADDER}, root=tmp_path)


def test_a_table_names_the_seed_of_its_episodes(tmp_path):
    """An evaluation's seed beside its episodes (a training run's `seed` is not the episodes':
    not shown); in a ladder table one line under it where every cell's are the same, else a
    column."""
    env = "TetherNavigate_OpenReach-v3"
    write(tmp_path / "e.json", [random_row(0.5)], {"env_id": env, "env_kwargs": {}, "seed": 7})
    trained = {"env_id": env, "env_kwargs": {}, "seed": 0, "timesteps": 10}
    write(tmp_path / "t.json", [{**random_row(0.5), "name": "sac"}], trained)
    table = tables.success_table({"*.json": LADDER}, root=tmp_path).splitlines()
    assert table[2].startswith(f"| `{env}` | defaults | random | 1,000 (seed 7) | 50.0% [")
    assert table[3].startswith(f"| `{env}` | defaults | sac | 1,000 | 50.0% [")
    ladder = tables.ladder_table({"e.json": LADDER}, ["random"], root=tmp_path)
    assert "\n\nEvery cell on the same episodes: 1,000 from seed 7.\n\n" in ladder
    other = {"env_id": "TetherNavigate_WallReach-v3", "env_kwargs": {}, "seed": 8}
    write(tmp_path / "f.json", [random_row(0.25)], other)
    ladder = tables.ladder_table({"[ef].json": LADDER}, ["random"], root=tmp_path)
    assert ladder.splitlines()[0] == "| env | episodes (seed) | random |"
    assert ladder.splitlines()[3] == "| `TetherNavigate_WallReach-v3` | 1,000 (seed 8) | 25.0% |"


def test_a_success_header_promises_an_interval_only_where_the_rows_show_one(tmp_path):
    """A file with successes and episodes but no interval (SAC + HER as an outside user writes
    it): the Wilson interval of its counts, as tether-evaluate computes it. A rate that is no
    whole count of its episodes: no interval, and the header says none."""
    setup = {"env_id": "TetherNavigate_OpenReachSparse-v3", "env_kwargs": {}, "seed": 0}
    write(tmp_path / "a.json", [{"name": "sac", "episodes": 500, "success_rate": 0.264}], setup)
    table = tables.success_table({"a.json": LADDER}, root=tmp_path).splitlines()
    low, high = wilson_interval(132, 500)
    assert table[0].endswith("| success [95% CI] |")
    assert table[2].endswith(f"| 26.4% [{100 * low:.1f}, {100 * high:.1f}] |")
    write(tmp_path / "b.json", [{"name": "sac", "episodes": 500, "success_rate": 0.2641}], setup)
    table = tables.success_table({"b.json": LADDER}, root=tmp_path).splitlines()
    assert table[0].endswith("| success |") and table[2].endswith("| 26.4% |")


def test_every_success_row_the_docs_show_names_its_episodes_seed():
    """The README's headline rows (the cards' held-out episodes) and the Results page's ladder
    (the test episodes): each row of a success table shows the seed its file records."""
    checked = 0
    for page in PAGES:
        text = page.read_text()
        calls = [*macros.PLACEHOLDER.findall(text), *(m[2] for m in readme.README_BLOCK.finditer(
            text))] if page.name == "README.md" else macros.PLACEHOLDER.findall(text)  # fmt: skip
        for call in calls:
            name, args, _ = macros.parse_call(call)
            if name != "success_table":
                continue
            seeds = {
                read["seed"]
                for pattern in args[0]
                for path in results.files_of(pattern, ROOT)
                if (read := results.read_results(path))["seed"] is not None
            }
            rows = [line for line in macros.expand(call).splitlines() if line.startswith("| `")]
            for seed in seeds:
                assert any(f"(seed {seed:,})" in row for row in rows), f"{page.name}: {call[:60]}"
                checked += 1
    assert checked >= 4


def test_one_agent_on_one_set_of_episodes_is_one_number():
    """The files the docs' success and ladder tables read: an agent (a planner as the ladder
    or a card names it) on one env with its arguments (the control mode, `coast`), episodes and
    seed has one success rate."""
    seen: dict[tuple, tuple[float, str]] = {}
    for page in PAGES:
        text = page.read_text()
        calls = [*macros.PLACEHOLDER.findall(text), *(m[2] for m in readme.README_BLOCK.finditer(
            text))]  # fmt: skip
        for call in calls:
            name, args, _ = macros.parse_call(call)
            if name not in ("success_table", "ladder_table"):
                continue
            for path in (p for pattern in args[0] for p in results.files_of(pattern, ROOT)):
                data = results.read_results(path)
                for agent, row in data["agents"].items():
                    kwargs = json.dumps(data["env_kwargs"], sort_keys=True)
                    key = (data["env_id"], kwargs, agent.removesuffix(" planner"),
                           row["episodes"], data["seed"])  # fmt: skip
                    where = f"{path.relative_to(ROOT)} ({page.name})"
                    rate, first = seen.setdefault(key, (row["success_rate"], where))
                    assert rate == row["success_rate"], f"{key}: {rate} in {first}, {where}"
    assert seen


def test_the_readme_s_tether_evaluate_line_plays_its_headline_table_s_episodes():
    """The README's `tether-evaluate ... --agents pretrained greedy` prints the numbers of the
    headline table under it: the card's held-out seed and episodes."""
    lines = [words for block in blocks(ROOT / "README.md") if block.language == "bash"
             for words in commands(block.code)
             if words[0] == "tether-evaluate" and "pretrained" in words]  # fmt: skip
    assert lines
    for words in lines:
        args = evaluate.build_parser().parse_args(words[1:])
        facts = pretrained.card(pretrained.for_env("pretrained", args.env, {}))
        assert args.seed == facts["held_out"]["seed"], " ".join(words)
        episodes = evaluate.EPISODES if args.episodes is None else args.episodes
        assert episodes == facts["held_out"]["episodes"], " ".join(words)


def test_tether_evaluate_names_the_seed_of_its_episodes(capsys):
    """The first line says how many episodes, from which seed and why, with or without a
    saved model among the agents; a pretrained agent's why names its card's seed."""
    evaluate.main(["--agents", "oracle", "--episodes", "4", "--no-progress-bar"])
    first = capsys.readouterr().out.splitlines()[0]
    assert first == "tether-evaluate: 4 episodes from seed 0 (--episodes given, else the defaults)"
    evaluate.main(["--agents", "oracle", "--episodes", "4", "--seed", "9", "--no-progress-bar"])
    assert capsys.readouterr().out.splitlines()[0] == (
        "tether-evaluate: 4 episodes from seed 9 (--episodes and --seed)"
    )
    args = evaluate.build_parser().parse_args(["--agents", "pretrained", "oracle"])
    episodes = evaluate.episodes_to_play(args, args.agents)
    assert (episodes.count, episodes.seed) == (evaluate.EPISODES, evaluate.SEED)
    card = pretrained.card("pretrained")["held_out"]["seed"]
    assert episodes.line().endswith(f"(the defaults; a pretrained agent's card is on seed {card}'s "
                                    "episodes)")  # fmt: skip
