"""The docs' generated parts: results tables read from the repository's results files, the
command-line reference of the console scripts, the ladder's ids; and the docstrings' tables
joined to one row per entry (`JoinTableRows`, a griffe extension in mkdocs.yml).

A page (or the README) writes a placeholder, a call of one of `MACROS` with literal arguments:

    {{ success_table({"results/ladder/*_setup.json": "python benchmarks/ladder.py"}) }}
    {{ cli_help("tether-train --env TetherNavigate-v3") }}

MkDocs runs this file as a hook (`hooks:` in mkdocs.yml): `on_page_markdown` replaces every
placeholder of a page with its Markdown before the page is rendered, so no number on a results
page is typed by hand, and each table says which command regenerates its files. The README is
static Markdown: its table sits between `<!-- results: CALL -->` and `<!-- /results -->`, and

    python docs/hooks.py --readme          # rewrites that table from the files
    python docs/hooks.py --readme --check  # exit status 1 if the README's table is stale

(`tests/contracts/test_docs.py` runs the check).
"""

from __future__ import annotations

import argparse
import ast
import contextlib
import glob
import io
import json
import os
import re
import sys
import textwrap
from collections.abc import Callable
from importlib import import_module, metadata
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
"""The repository: results paths in placeholders are relative to it."""
PLACEHOLDER = re.compile(r"\{\{\s*(\w+\(.*?\))\s*\}\}", re.DOTALL)
LADDER_YARDSTICKS = ("greedy planner", "lookahead planner", "random")
"""The agents every baseline summary also plays, in the order `ladder_seeds_table` shows."""
README_BLOCK = re.compile(r"(<!-- results: (.*?) -->\n)(.*?)(<!-- /results -->)", re.DOTALL)


# --- results files -----------------------------------------------------------------------


def read_results(path: Path) -> dict[str, Any]:
    """One results file as `{env_id, env_kwargs, seed, episodes, agents: {name: result}}`.

    Understood: the JSON of `tether-evaluate --json` and `benchmarks/ladder.py`, a run's
    `results.json` (`tether-train`), a flat JSON with one `success_rate` (a benchmark script's;
    the agent is named by its `agent` key, else the file's stem), and a pretrained agent's model
    card (YAML front matter, `tether_gym/agents/pretrained/*.md`).
    """
    if path.suffix == ".md":
        import yaml

        from tether_gym.agents.planned import playing

        front = yaml.safe_load(path.read_text().split("---\n", 2)[1])
        held_out = front["held_out"]
        params = front.get("hyperparams") or {}
        planned = playing(params)
        name = front["name"]
        if planned is not None:
            name += f" ({planned.title.format(planner=params[planned.key])})"
        agents = {
            (name if key == "policy" else key): value
            for key, value in held_out.items()
            if isinstance(value, dict)
        }
        for value in agents.values():
            value.setdefault("episodes", held_out["episodes"])
        return {
            "env_id": front["env_id"],
            "env_kwargs": front.get("env_kwargs") or {},
            "seed": held_out["seed"],
            "agents": agents,
        }
    data = json.loads(path.read_text())
    if "results" in data:
        agents = {result["name"]: result for result in data["results"]}
    else:
        agents = {data.get("agent", path.stem): data}
    kwargs = dict(data.get("env_kwargs") or {})
    if "control" in data:
        kwargs.setdefault("control", data["control"])
    return {"env_id": data["env_id"], "env_kwargs": kwargs, "seed": data.get("seed"),
            "agents": agents}  # fmt: skip


def files_of(pattern: str, root: Path) -> list[Path]:
    """The files a glob relative to `root` names, sorted; ValueError if there are none."""
    paths = sorted(Path(p) for p in glob.glob(str(root / pattern)))
    if not paths:
        raise ValueError(f"no results file matches {pattern!r} under {root}")
    return paths


def percent(result: dict[str, Any]) -> str:
    """Success as `98.2% [98.0, 98.5]` (with the 95% interval when the file has it)."""
    text = f"{100 * result['success_rate']:.1f}%"
    ci = result.get("success_ci")
    if ci:
        text += f" [{100 * ci[0]:.1f}, {100 * ci[1]:.1f}]"
    return text


def kwargs_text(kwargs: dict[str, Any]) -> str:
    return " ".join(f"{k}:{v}" for k, v in kwargs.items()) if kwargs else "defaults"


_README_NOTES = False
"""Set while the README's tables render: their notes stay one line of static Markdown."""


def sources_line(sources: dict[str, str]) -> str:
    """The note under a table: its files, grouped by the command that writes them. On a page,
    a collapsed block (a `??? info`) with each command folded in a code block of its own; in
    the README, one italic line."""
    by_command: dict[str, list[str]] = {}
    for pattern, command in sources.items():
        by_command.setdefault(command, []).append(pattern)
    if _README_NOTES:
        parts = [", ".join(f"`{p}`" for p in ps) + f", written by `{c}`"
                 for c, ps in by_command.items()]  # fmt: skip
        return "\n\n*Read from " + "; ".join(parts) + ".*\n"
    files = sum(len(p) for p in by_command.values())
    title = f"Read from {files} file{'s' * (files > 1)}" + (
        f", written by {len(by_command)} commands" if len(by_command) > 1 else ""
    )
    body = []
    for command, patterns in by_command.items():
        body.append(", ".join(f"`{p}`" for p in patterns) + ", written by:")
        body.append(f"```bash\n{fold_command(command)}\n```")
    block = "\n\n".join(body)
    return f'\n\n??? info "{title}"\n\n{textwrap.indent(block, "    ")}\n'


def fold_command(command: str, width: int = 88) -> str:
    """A long shell command folded before its options (` \\` continuations, shell-valid), so it
    reads without scrolling; quoted arguments are never split. A short one as it is."""
    if len(command) <= width:
        return command
    words, word, quote = [], "", ""
    for char in command:  # split on spaces outside quotes, keeping each word's own text
        if quote:
            quote = "" if char == quote else quote
        elif char in "'\"":
            quote = char
        elif char == " ":
            words.append(word)
            word = ""
            continue
        word += char
    words.append(word)
    lines = [words[0]]
    for word in words[1:]:
        if word.startswith("-") or len(lines[-1]) + len(word) + 1 > width:
            lines.append("  " + word)
        else:
            lines[-1] += " " + word
    return " \\\n".join(lines)


def _check_sources(sources: dict[str, str]) -> None:
    if not isinstance(sources, dict) or not sources:
        raise ValueError("a results table needs {files glob: command that writes them}")
    for pattern, command in sources.items():
        if not (isinstance(command, str) and command.strip()):
            raise ValueError(f"{pattern}: the command that regenerates it is missing")


def success_table(
    sources: dict[str, str], agents: list[str] | None = None, root: Path = ROOT
) -> str:
    """One row per results file and agent: env, its arguments, agent, episodes, success
    [95% CI] (and maneuvers to the goal where the file has them). `sources` maps a glob of
    results files to the command that writes them; `agents` keeps those agents, in that order.
    """
    _check_sources(sources)
    rows = []
    for pattern in sources:
        for path in files_of(pattern, root):
            data = read_results(path)
            names = agents if agents is not None else list(data["agents"])
            for name in names:
                if name not in data["agents"]:
                    continue
                result = data["agents"][name]
                maneuvers = result.get("maneuvers_mean")
                rows.append(
                    f"| `{data['env_id']}` | {kwargs_text(data['env_kwargs'])} | {name} | "
                    f"{result['episodes']:,} | {percent(result)} | "
                    f"{'-' if maneuvers is None else f'{maneuvers:.2f}'} |"
                )
    if not rows:
        raise ValueError(f"no agent of {agents} in {list(sources)}")
    header = (
        "| env | arguments | agent | episodes | success [95% CI] | maneuvers to goal |\n"
        "|---|---|---|---:|---|---:|\n"
    )
    return header + "\n".join(rows) + sources_line(sources)


def ladder_table(
    sources: dict[str, str], agents: list[str], by_control: bool = False, root: Path = ROOT
) -> str:
    """One row per env id, one column per agent: success [95% CI]. With `by_control`, one
    column per control mode (`env_kwargs["control"]`) and agent. A cell no file fills is
    blank; two files filling one cell are an error."""
    _check_sources(sources)
    table: dict[str, dict[str, str]] = {}
    columns: list[str] = [] if by_control else list(agents)
    for pattern in sources:
        for path in files_of(pattern, root):
            data = read_results(path)
            row = table.setdefault(data["env_id"], {})
            for name in agents:
                if name not in data["agents"]:
                    continue
                column = name
                if by_control:
                    column = f"{name}, {data['env_kwargs'].get('control', 'setup')}"
                    if column not in columns:
                        columns.append(column)
                if column in row:
                    raise ValueError(f"{path.name}: a second result for {data['env_id']}, "
                                     f"{column}")  # fmt: skip
                row[column] = percent(data["agents"][name])
    header = "| env | " + " | ".join(columns) + " |\n|---|" + "---|" * len(columns) + "\n"
    lines = [
        f"| `{env_id}` | " + " | ".join(row.get(column, "") for column in columns) + " |"
        for env_id, row in table.items()
    ]
    return header + "\n".join(lines) + sources_line(sources)


def seeds_table(sources: dict[str, str], agents: list[str] | None = None, root: Path = ROOT) -> str:
    """One row per agent of each summary over seeds (`benchmarks/baselines.py`): the runs'
    timesteps and median train time, and each agent's mean success on the test episodes over
    the seeds with its 95% t interval and the worst seed (the planners and random play the same
    episodes in every run). `agents` keeps those agents only."""
    _check_sources(sources)
    rows, notes = [], []
    for pattern in sources:
        for path in files_of(pattern, root):
            data = json.loads(path.read_text())
            if "paired" in data:
                notes.append(_paired_line(data))
            minutes = sorted(data["train_seconds"])[len(data["train_seconds"]) // 2] / 60
            for result in data["results"]:
                if agents is not None and result["name"] not in agents:
                    continue
                rows.append(
                    f"| `{data['env_id']}` | {kwargs_text(data['env_kwargs'])} | "
                    f"{result['name']} | {len(data['seeds'])} | {data['timesteps']:,} | "
                    f"{minutes:.1f} | {percent(result)} | {100 * result['worst']:.1f}% |"
                )
    header = (
        "| env | arguments | agent | seeds | timesteps | train min (median) | "
        "success, mean [95% CI] | worst seed |\n|---|---|---|---:|---:|---:|---|---:|\n"
    )
    return header + "\n".join(rows) + "".join(notes) + sources_line(sources)


def ladder_seeds_table(sources: dict[str, str], root: Path = ROOT) -> str:
    """One row per summary over seeds (`benchmarks/baselines.py`), for comparing rungs and
    control modes at a glance: the env, its arguments and the zoo's overridden policy, the learned
    agent's best models' mean success with its 95% t interval and worst seed, the median train
    time, and the planners and random on the same test episodes."""
    _check_sources(sources)
    rows = []
    for pattern in sources:
        for path in files_of(pattern, root):
            data = json.loads(path.read_text())
            by_name = {result["name"]: result for result in data["results"]}
            learned = next(r for name, r in by_name.items() if name.endswith("(best)"))
            agent = _agent_cell(data["algo"], data.get("hyperparams", {}))
            minutes = sorted(data["train_seconds"])[len(data["train_seconds"]) // 2] / 60
            yardsticks = " | ".join(
                f"{100 * by_name[name]['success_rate']:.1f}%" for name in LADDER_YARDSTICKS
            )
            rows.append(
                f"| `{data['env_id']}` | {kwargs_text(data['env_kwargs'])} | "
                f"{agent} | {len(data['seeds'])} | "
                f"{data['timesteps']:,} | {minutes:.0f} | {percent(learned)} | "
                f"{100 * learned['worst']:.1f}% | {yardsticks} | {_paired_cell(data)} |"
            )
    header = (
        "| env | arguments | agent | seeds | timesteps | train min (median) | "
        "success, mean [95% CI] | worst seed | greedy | lookahead | random | paired |\n"
        "|---|---|---|---:|---:|---:|---|---:|---:|---:|---:|---|\n"
    )
    return header + "\n".join(rows) + sources_line(sources)


def _agent_cell(algo: str, hyperparams: dict[str, str]) -> str:
    """The algorithm and the policy a summary's runs overrode the zoo with; other overrides by
    name only (their values are in the command under the table)."""
    policy = hyperparams.get("policy")
    others = [key for key in hyperparams if key != "policy"]
    text = algo.upper() + (f" {policy}" if policy else "")
    return text + (f", {' '.join(others)} as in the command" if others else "")


def _paired_cell(data: dict[str, Any]) -> str:
    """A summary's paired comparison in a few words: the reference's success and on how many
    seeds the best model won or lost significantly (McNemar p < 0.05) on the same episodes."""
    paired = data.get("paired")
    if paired is None:
        return "-"
    seeds = paired["per_seed"]
    significant = [row for row in seeds if row["mcnemar_p"] < 0.05]
    ahead = sum(row["wins"] > row["losses"] for row in significant)
    behind = len(significant) - ahead
    return (
        f"{paired['reference']} {100 * paired['reference_success_rate']:.1f}%: "
        f"ahead on {ahead}, behind on {behind} of {len(seeds)} seeds (p < 0.05)"
    )


def _paired_line(data: dict[str, Any]) -> str:
    """A summary's paired comparison (`baselines.py --paired`) in words: per seed, the best
    model's wins and losses against the reference on the same episodes, and McNemar's p."""
    paired = data["paired"]
    seeds = "; ".join(
        f"seed {row['seed']}: {row['wins']} won, {row['losses']} lost (p {row['mcnemar_p']:.2g})"
        for row in paired["per_seed"]
    )
    return (
        f"\n\n`{data['env_id']}`, each seed's best model against {paired['reference']} "
        f"({100 * paired['reference_success_rate']:.1f}%) on the same {paired['episodes']:,} "
        f"episodes: {seeds}."
    )


def planner_table(sources: dict[str, str], root: Path = ROOT) -> str:
    """One row per planner and task of a planner benchmark (`benchmarks/planners.py`): each
    implementation's decisions per second at each batch size on one core (the ratio to numpy's
    measured in the same run), the recorded decision states where it picks numpy's maneuver,
    and its success on the held-out episodes."""
    _check_sources(sources)
    blocks = []
    for pattern in sources:
        for path in files_of(pattern, root):
            data = json.loads(path.read_text())
            rates, success = data["decisions_per_second"], data.get("success", {})
            agreement = data.get("agreement", {})
            first = next(iter(rates.values()))
            batches = list(next(iter(next(iter(first.values())).values())))
            columns = [f"{i} batch {b}" for b in batches for i in rates]
            columns += [f"{i} same choice" for i in agreement]
            columns += [f"{i} success" for i in success]
            lines = ["| planner | task | " + " | ".join(columns) + " |",
                     "|---|---|" + "---:|" * len(columns)]  # fmt: skip
            for planner, by_task in first.items():
                for task in by_task:
                    cells = []
                    for batch in batches:
                        for implementation, by_planner in rates.items():
                            rate = by_planner[planner][task][batch]
                            ratio = rate / rates["numpy"][planner][task][batch]
                            cells.append(f"{rate:,.0f}" + ("" if implementation == "numpy"
                                                          else f" ({ratio:.1f}x)"))  # fmt: skip
                    for by_planner in agreement.values():
                        a = by_planner[planner][task]
                        cells.append(f"{a['same']:,} of {a['states']:,}")
                    cells += [percent(by_planner[planner][task]) for by_planner in success.values()]
                    lines.append(f"| {planner} | {task} | " + " | ".join(cells) + " |")
            blocks.append("\n".join(lines))
    return "\n\n".join(blocks) + sources_line(sources)


def imitation_table(sources: dict[str, str], root: Path = ROOT) -> str:
    """One row per picker of an imitation benchmark (`benchmarks/imitation.py`): how often its
    pick among the teacher's candidate aims is among the best on the held-out states, over all
    of them and where the goal itself is not among the best; the students' mean over network
    seeds with its 95% t interval."""
    _check_sources(sources)
    rows = []
    for pattern in sources:
        for path in files_of(pattern, root):
            data = json.loads(path.read_text())
            pickers = {"always the goal (the direct shot)": data["goal_in_best"],
                       "a random candidate": data["random_in_best"]}  # fmt: skip
            for name, rates in data["students"].items():
                pickers[f"student: {name}, {len(rates['in_best']['seeds'])} seeds"] = rates
            for name, rates in pickers.items():
                rows.append(
                    f"| `{data['env_id']}` | {data['teacher']}, {data['candidates']} | "
                    f"{data['held_out']:,} of {data['states']:,} | "
                    f"{100 * data['detour_share']:.1f}% | {name} | "
                    f"{_rate_cell(rates['in_best'])} | {_rate_cell(rates['in_best_detour'])} |"
                )
    header = (
        "| env | teacher, candidates | held-out states | direct shot not among the best | picker | "
        "pick among the best | where a detour is needed |\n"
        "|---|---|---:|---:|---|---:|---:|\n"
    )
    return header + "\n".join(rows) + sources_line(sources)


def fuzz_table(sources: dict[str, str], root: Path = ROOT) -> str:
    """The public-API fuzz's findings (`benchmarks/fuzz_navigate.py`): one row per class, and
    per results file the transitions with that finding among the single env's steps and among
    the vector env's transitions."""
    _check_sources(sources)
    runs = [(path, json.loads(path.read_text())) for p in sources for path in files_of(p, root)]
    classes = list(dict.fromkeys(c for _, data in runs for c in data["holes"] + data["notes"]))
    header = "| finding | " + " | ".join(
        f"`{path.stem}` single ({data['counts']['single']['steps']:,} steps) | "
        f"`{path.stem}` vector ({data['counts']['vector']['steps']:,})"
        for path, data in runs
    )
    rows = [header + " |", "|---|" + "---:|---:|" * len(runs)]
    for name in classes:
        cells = []
        for _, data in runs:
            for kind in ("single", "vector"):
                count = data["counts"][kind]["counts"].get(name)
                cells.append("-" if count is None else f"{count:,}")
        note = " (not a hole)" if any(name in data["notes"] for _, data in runs) else ""
        rows.append(f"| `{name}`{note} | " + " | ".join(cells) + " |")
    return "\n".join(rows) + sources_line(sources)


def cold_start_table(sources: dict[str, str], root: Path = ROOT) -> str:
    """What a first run costs (`benchmarks/cold_start.py`): per entry point, the seconds of its
    first call and of its whole process with an empty numba cache, on the revision measured and
    on the one it was measured against in the same run, and their ratio."""
    _check_sources(sources)
    rows = []
    for path in (path for p in sources for path in files_of(p, root)):
        data = json.loads(path.read_text())
        against = data["against"]
        rows.append(
            f"| entry | first call, s | process, s | first call at `{against}`, s | "
            f"process at `{against}`, s | process, ratio |\n|---|---:|---:|---:|---:|---:|"
        )
        for name, trees in data["results"].items():
            now, before = trees["this tree"], trees[against]
            rows.append(
                f"| {name} | {now['entry']:.1f} | {now['wall']:.1f} | {before['entry']:.1f} | "
                f"{before['wall']:.1f} | {now['wall'] / before['wall']:.2f} |"
            )
    return "\n".join(rows) + sources_line(sources)


def _rate_cell(rate: float | dict[str, Any]) -> str:
    """A rate as a percentage, or a mean over seeds with its 95% interval."""
    if not isinstance(rate, dict):
        return f"{100 * rate:.1f}%"
    low, high = rate["ci"]
    return f"{100 * rate['mean']:.1f}% [{100 * low:.1f}, {100 * high:.1f}]"


# --- command-line help and ids -------------------------------------------------------------


def _entry_point(program: str) -> Callable[[list[str]], Any]:
    """The `main` of a console script (`tether-train`) or of a module (`-m package.module`)."""
    if program.startswith("-m "):
        return import_module(program[3:]).main
    (point,) = metadata.entry_points(group="console_scripts", name=program)
    return point.load()


class _HelpRequested(BaseException):
    """Raised in place of printing a parser's help: carries the parser (a BaseException, as
    SystemExit is, so that a `main` catching its errors lets it through)."""

    def __init__(self, parser: argparse.ArgumentParser) -> None:
        super().__init__(parser.prog)
        self.parser = parser


def help_parser(command: str) -> argparse.ArgumentParser:
    """The argparse parser that `command --help` prints the help of.

    `command` is the program and any arguments before `--help`, e.g. `"tether-train --env
    TetherNavigate-v3"`; `"python -m tether_gym.agents.record"` runs that module's `main`.
    Any `main` that builds its parsers with argparse works, subcommands included (`"tether
    train"` gives the subcommand's parser): the parser is caught where it would print.
    """
    words = command.split()
    if words[:2] == ["python", "-m"]:
        program, argv = f"-m {words[2]}", words[3:]
    else:
        program, argv = words[0], words[1:]
    main = _entry_point(program)

    def caught(parser: argparse.ArgumentParser, file=None) -> None:
        raise _HelpRequested(parser)

    saved = sys.argv[0], argparse.ArgumentParser.print_help
    sys.argv[0] = program.removeprefix("-m ")  # a parser's default prog
    argparse.ArgumentParser.print_help = caught
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            main([*argv, "--help"])
    except _HelpRequested as requested:
        return requested.parser
    except SystemExit:
        pass
    finally:
        sys.argv[0], argparse.ArgumentParser.print_help = saved
    raise ValueError(f"{command} --help printed no argparse help")


@contextlib.contextmanager
def _help_width(columns: int = 100):
    """argparse's help `columns` wide (it reads COLUMNS)."""
    saved = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = str(columns)
    try:
        yield
    finally:
        if saved is None:
            os.environ.pop("COLUMNS", None)
        else:
            os.environ["COLUMNS"] = saved


def cli_help(command: str) -> str:
    """The command-line reference of a console script (or `python -m module`), from its
    argparse parser (`help_parser`): the usage in a text block, the description, one table per
    argument group (an option and its meaning per row, a subcommand per row), the epilog."""
    with _help_width(88):  # the usage block fits the page's width
        return parser_markdown(help_parser(command))


def parser_markdown(parser: argparse.ArgumentParser) -> str:
    """Any argparse parser as Markdown (see `cli_help`); `%(default)s` and the like expanded
    as `--help` expands them."""
    formatter = parser._get_formatter()
    parts = [f"```text\n{parser.format_usage().strip()}\n```"]
    if parser.description:
        parts.append(help_prose(parser.description))
    for group in parser._action_groups:
        actions = [a for a in group._group_actions if a.help != argparse.SUPPRESS]
        if not actions:
            continue
        title = f"**{group.title}**" if group.title else ""
        if group.description:
            title += (
                f": {help_prose(group.description)}" if title else help_prose(group.description)
            )
        kind = "argument" if all(not a.option_strings for a in actions) else "option"
        if any(isinstance(a, argparse._SubParsersAction) for a in actions):
            kind = "command"
        rows = [f"| {kind} | meaning |", "|---|---|"]
        for action in actions:
            if isinstance(action, argparse._SubParsersAction):
                rows += [
                    f"| `{choice.dest}` | {_cell(formatter._expand_help(choice))} |"
                    for choice in action._get_subactions()
                ]
                continue
            meaning = formatter._expand_help(action) if action.help else ""
            rows.append(f"| {_invocation(formatter, action)} | {_cell(meaning)} |")
        parts += [title, "\n".join(rows)] if title else ["\n".join(rows)]
    if parser.epilog:
        parts.append(help_prose(parser.epilog))
    return "\n\n".join(parts) + "\n"


def _invocation(formatter: argparse.HelpFormatter, action: argparse.Action) -> str:
    """`-p`, `--param VALUE`: each option string, the arguments after the last one only."""
    if not action.option_strings:
        return f"`{formatter._format_action_invocation(action)}`"
    names = [f"`{name}`" for name in action.option_strings]
    if action.nargs != 0:
        metavar = formatter._get_default_metavar_for_optional(action)
        names[-1] = f"`{action.option_strings[-1]} {formatter._format_args(action, metavar)}`"
    return ", ".join(names)


def _cell(text: str) -> str:
    """Help text as one table cell: on one line, its `|` and `<` escaped."""
    return _escape(" ".join(text.split())).replace("|", "\\|")


def _escape(text: str) -> str:
    """`<` outside code spans as `&lt;` (`runs/<name>` is no HTML tag)."""
    parts = re.split(r"(`[^`]*`)", text)
    return "".join(p if p.startswith("`") else p.replace("<", "&lt;") for p in parts)


def help_prose(text: str) -> str:
    """A parser's description or epilog (written as Markdown, as the docstrings they often
    are) for a page: its tables set off by blank lines and joined to one row per entry,
    indented blocks kept, `<` escaped elsewhere."""
    lines: list[str] = []
    for line in textwrap.dedent(text).strip("\n").splitlines():
        table = _is_row(line)
        if lines and lines[-1].strip() and table != _is_row(lines[-1]):
            lines.append("")  # a table needs blank lines around it
        listed = _LISTED.match(line)
        if listed:  # argparse's "  name   what it does" (a dispatcher's commands): a list
            if lines and lines[-1].strip() and not lines[-1].startswith("- "):
                lines.append("")
            lines.append(f"- `{listed[1]}`: {_escape(listed[2])}")
            continue
        if lines and lines[-1].startswith("- ") and line.strip():
            lines.append("")
        lines.append(line if table or line.startswith("    ") else _escape(line))
    return join_table_rows("\n".join(lines))


_LISTED = re.compile(r"^ {2,3}(\S+(?: \S+)*?) {2,}(\S.*)$")


# --- tables in docstrings ------------------------------------------------------------------

_SEPARATOR = re.compile(r"^\s*\|?(\s*:?-+:?\s*\|)+\s*(:?-+:?\s*)?$")


def _is_row(line: str) -> bool:
    return line.strip().startswith("|") and line.strip().endswith("|")


def _cells(line: str) -> list[str]:
    return [c.strip() for c in re.split(r"(?<!\\)\|", line.strip()[1:-1])]


def join_table_rows(text: str) -> str:
    """Markdown `text` with each table's continuation rows joined: in the docstrings' tables
    (Gymnasium's convention, kept under the line length), a row whose first cell is empty
    carries on the row above it, each cell the wrapped end of that row's cell. The page shows
    one row per entry; `help()` shows the source as it is."""
    lines = text.split("\n")
    out: list[str] = []
    i = 0
    while i < len(lines):
        line = lines[i]
        if not (_is_row(line) and i + 1 < len(lines) and _SEPARATOR.match(lines[i + 1])):
            out.append(line)
            i += 1
            continue
        indent = line[: len(line) - len(line.lstrip())]
        out += [line, lines[i + 1]]
        rows: list[list[str]] = []
        i += 2
        while i < len(lines) and _is_row(lines[i]):
            cells = _cells(lines[i])
            if rows and not cells[0] and len(cells) == len(rows[-1]):
                rows[-1] = [f"{a} {b}".strip() for a, b in zip(rows[-1], cells, strict=True)]
            else:
                rows.append(cells)
            i += 1
        out += [f"{indent}| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(out)


try:
    from griffe import Extension
except ImportError:  # only mkdocstrings needs it
    Extension = object  # type: ignore[assignment,misc]


class JoinTableRows(Extension):
    """A griffe extension (mkdocs.yml's mkdocstrings `extensions`): every docstring's tables
    one row per entry (`join_table_rows`)."""

    def on_instance(self, *, obj, **kwargs) -> None:
        if obj.docstring is not None:
            obj.docstring.value = join_table_rows(obj.docstring.value)


def ladder_ids() -> str:
    """TetherNavigate's ladder: each registered id and its arguments, from `tether_gym.ladder`."""
    from tether_gym import ladder

    lines = ["| id | arguments |", "|---|---|"]
    for env_id, kwargs in ladder.ids().items():
        shown = {k: ("the Wall map" if v == ladder.WALL else v) for k, v in kwargs.items()}
        lines.append(f"| `{env_id}` | {kwargs_text(shown)} |")
    return "\n".join(lines) + "\n"


MACROS: dict[str, Callable[..., str]] = {
    "success_table": success_table,
    "ladder_table": ladder_table,
    "seeds_table": seeds_table,
    "ladder_seeds_table": ladder_seeds_table,
    "planner_table": planner_table,
    "imitation_table": imitation_table,
    "fuzz_table": fuzz_table,
    "cold_start_table": cold_start_table,
    "cli_help": cli_help,
    "ladder_ids": ladder_ids,
}
"""The placeholders a page may use."""
RESULTS_MACROS = (
    "success_table",
    "ladder_table",
    "seeds_table",
    "ladder_seeds_table",
    "planner_table",
    "imitation_table",
    "fuzz_table",
    "cold_start_table",
)


def parse_call(text: str) -> tuple[str, list[Any], dict[str, Any]]:
    """A placeholder's macro name and literal arguments; ValueError for anything else."""
    call = ast.parse(text, mode="eval").body
    if not (isinstance(call, ast.Call) and isinstance(call.func, ast.Name)):
        raise ValueError(f"not a macro call: {text!r}")
    if call.func.id not in MACROS:
        raise ValueError(f"unknown macro {call.func.id!r} (known: {sorted(MACROS)})")
    args = [ast.literal_eval(arg) for arg in call.args]
    kwargs = {kw.arg: ast.literal_eval(kw.value) for kw in call.keywords if kw.arg}
    return call.func.id, args, kwargs


def expand(call_text: str, root: Path = ROOT) -> str:
    """The Markdown of one placeholder's call (results paths relative to `root`)."""
    name, args, kwargs = parse_call(call_text)
    if name in RESULTS_MACROS:
        kwargs["root"] = root
    return MACROS[name](*args, **kwargs)


def render(markdown: str, root: Path = ROOT) -> str:
    """`markdown` with every placeholder replaced by its Markdown."""
    return PLACEHOLDER.sub(lambda m: expand(m.group(1), root), markdown)


def on_page_markdown(markdown: str, page, config, files) -> str:  # MkDocs hook
    try:
        return render(markdown)
    except Exception as error:  # the page's name makes a failed build easy to place
        raise RuntimeError(f"{page.file.src_path}: {error}") from error


# --- the README's table --------------------------------------------------------------------


def readme_text(text: str, root: Path = ROOT) -> str:
    """The README with each `<!-- results: CALL -->` block rendered anew from the files."""
    global _README_NOTES
    _README_NOTES = True
    try:
        return README_BLOCK.sub(lambda m: m[1] + expand(m[2], root) + m[4], text)
    finally:
        _README_NOTES = False


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Render the README's results table.")
    parser.add_argument("--readme", action="store_true", help="rewrite README.md's tables")
    parser.add_argument("--check", action="store_true", help="only check: 1 if stale")
    args = parser.parse_args(argv)
    if not args.readme:
        parser.error("nothing to do: pass --readme")
    readme = ROOT / "README.md"
    text = readme.read_text()
    new = readme_text(text)
    if args.check:
        if new != text:
            print("README.md's results table is stale: python docs/hooks.py --readme")
            return 1
        return 0
    readme.write_text(new)
    return 0


if __name__ == "__main__":
    sys.exit(main())
