"""The results tables' macros: each reads its files through `docgen.results` (one schema) and
ends with the note naming the files and the command that writes them; and the ladder's ids.

A macro's `style` is "page" (the note a collapsed block) or "readme" (one italic line: the
README is static Markdown).
"""

from __future__ import annotations

import shlex
import textwrap
from pathlib import Path
from typing import Any

import numpy as np

from docgen import ROOT
from docgen.results import (
    control_label,
    episodes_text,
    files_of,
    interval,
    kwargs_text,
    percent,
    read_file,
    read_results,
    train_minutes,
)
from tether_gym.evaluation.statistics import t_interval

STYLES = ("page", "readme")


def sources_line(
    sources: dict[str, str], style: str = "page", root: Path = ROOT, lead: str = ""
) -> str:
    """The note under a table: its files, grouped by the command that writes them, each command
    as a shell reads it (`shell_command`). On a page, a collapsed block (a `??? info`) titled
    with the number of files its globs match, each command folded in a code block of its own;
    in the README, one italic line. `lead`, a sentence about the table's rows, goes before it:
    on a page its own paragraph, in the README the italic line's first sentence."""
    by_command: dict[str, list[str]] = {}
    for pattern, command in sources.items():
        by_command.setdefault(command, []).append(pattern)
    if style not in STYLES:
        raise ValueError(f"style must be one of {STYLES}, got {style!r}")
    requoted = [c for c in by_command if shell_command(c) != c]
    quoting = " (quoted for the shell: the file records it without the quotes)"
    if style == "readme":
        parts = [", ".join(f"`{p}`" for p in ps) + f", written by `{shell_command(c)}`"
                 + (quoting if c in requoted else "") for c, ps in by_command.items()]  # fmt: skip
        return "\n\n*" + (f"{lead} " if lead else "") + "Read from " + "; ".join(parts) + ".*\n"
    files = sum(len(files_of(p, root)) for p in sources)
    title = f"Read from {count(files, 'file')}" + (
        f", written by {len(by_command)} commands" if len(by_command) > 1 else ""
    )
    body = []
    for command, patterns in by_command.items():
        body.append(", ".join(f"`{p}`" for p in patterns) + ", written by"
                    + (quoting if command in requoted else "") + ":")  # fmt: skip
        body.append(f"```bash\n{fold_command(shell_command(command))}\n```")
    block = "\n\n".join(body)
    lead = f"\n\n{lead}" if lead else ""
    return f'{lead}\n\n??? info "{title}"\n\n{textwrap.indent(block, "    ")}\n'


SHELL_SPECIAL = frozenset("()<>;&|")
"""The characters a shell reads as syntax outside quotes (a word with one, unquoted, is a
syntax error or a redirection, not an argument)."""


def shell_words(command: str) -> list[str]:
    """`command` split at each space outside quotes, each word's own text kept (its quotes; an
    empty word between two spaces)."""
    words, word, quote = [], "", ""
    for char in command:
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
    return words


def _bare(word: str) -> str:
    """A word's characters outside its quotes."""
    bare, quote = "", ""
    for char in word:
        if quote:
            quote = "" if char == quote else quote
        elif char in "'\"":
            quote = char
        else:
            bare += char
    return bare


def shell_command(command: str) -> str:
    """`command` as a shell reads it, to paste into one. A results file written before commands
    were recorded with their quotes holds its arguments joined by spaces
    (`policy_kwargs:dict(features_extractor_class=X, net_arch=[64, 64])`); such an argument,
    its words rejoined while a bracket stays open, is quoted whole (`shlex.quote`), as is any
    word with a shell's special characters outside quotes. A command a shell reads already
    (each argument quoted where it needs it) comes back as it is; a comment (`# ...`) too."""
    merged: list[str] = []
    grouped: list[bool] = []
    comment, depth = "", 0
    for number, word in enumerate(words := [w for w in shell_words(command) if w]):
        if depth <= 0 and word.startswith("#"):  # a comment: the rest as it is
            comment = " ".join(words[number:])
            break
        if depth > 0:
            merged[-1] += " " + word
            grouped[-1] = True
        else:
            merged.append(word)
            grouped.append(False)
        bare = _bare(word)
        depth += sum(map(bare.count, "([{")) - sum(map(bare.count, ")]}"))
    quoted = [
        shlex.quote(word) if together or SHELL_SPECIAL & set(_bare(word)) else word
        for word, together in zip(merged, grouped, strict=True)
    ]
    text = " ".join([*quoted, comment] if comment else quoted)
    return command if " ".join(command.split()) == text else text


def fold_command(command: str, width: int = 88) -> str:
    """A long shell command folded before its options (` \\` continuations, shell-valid), so it
    reads without scrolling; quoted arguments are never split, nor `python -m MODULE`, nor a
    comment (`# ...`: a continuation would end there). A short one as it is."""
    if len(command) <= width:
        return command
    words = shell_words(command)
    first = 3 if words[1:2] == ["-m"] else 1  # `python -m MODULE` stays whole
    lines = [" ".join(words[:first])]
    comment = False
    for word in words[first:]:
        comment = comment or word.startswith("#")
        long = len(lines[-1]) + len(word) + 1 > width
        if word and not comment and (word.startswith("-") or long):
            lines.append("  " + word)
        else:
            lines[-1] += " " + word
    return " \\\n".join(lines)


def count(number: int, noun: str) -> str:
    """`number` and `noun`, plural but for one: `1 seed`, `5 seeds`."""
    return f"{number:,} {noun}{'s' * (number != 1)}"


def _check_sources(sources: dict[str, str]) -> None:
    if not isinstance(sources, dict) or not sources:
        raise ValueError("a results table needs {files glob: command that writes them}")
    for pattern, command in sources.items():
        if not (isinstance(command, str) and command.strip()):
            raise ValueError(f"{pattern}: the command that regenerates it is missing")


def success_table(
    sources: dict[str, str], agents: list[str] | None = None, root: Path = ROOT, style: str = "page"
) -> str:
    """One row per results file and agent: env, its arguments, agent, episodes and the seed they
    come from, success [95% CI] (the interval from the file, else from its counts,
    `results.interval`; the header says where a row has none), and maneuvers to the goal where
    the files record them (the column left out where none does). `sources` maps a glob of
    results files to the command that writes them; `agents` keeps those agents, in that
    order."""
    _check_sources(sources)
    rows, every_ci = [], True
    for pattern in sources:
        for path in files_of(pattern, root):
            data = read_results(path)
            names = agents if agents is not None else list(data["agents"])
            for name in names:
                if name not in data["agents"]:
                    continue
                result = data["agents"][name]
                result = {**result, "success_ci": interval(result)}
                every_ci &= result["success_ci"] is not None
                maneuvers = result.get("maneuvers_mean")
                rows.append((
                    f"| `{data['env_id']}` | {kwargs_text(data['env_kwargs'])} | {name} | "
                    f"{episodes_text(result['episodes'], data['seed'])} | {percent(result)} |",
                    "-" if maneuvers is None else f"{maneuvers:.2f}",
                ))  # fmt: skip
    if not rows:
        raise ValueError(f"no agent of {agents} in {list(sources)}")
    success = "success [95% CI]" if every_ci else "success"
    header = f"| env | arguments | agent | episodes (seed) | {success} |"
    align = "|---|---|---|---:|---|"
    if any(maneuvers != "-" for _, maneuvers in rows):
        header, align = header + " maneuvers to goal |", align + "---:|"
        lines = [f"{row} {maneuvers} |" for row, maneuvers in rows]
    else:
        lines = [row for row, _ in rows]
    return "\n".join([header, align, *lines]) + sources_line(sources, style, root)


def ladder_table(
    sources: dict[str, str],
    agents: list[str],
    by_control: bool = False,
    root: Path = ROOT,
    style: str = "page",
) -> str:
    """One row per env id, one column per agent: success [95% CI]. With `by_control`, one
    column per control mode and agent (`results.control_label`: `coast` named). The episodes
    the agents played and their seed: a line under the table where every cell's are the same,
    else a column. A cell no file fills is blank; two files filling one cell are an error."""
    _check_sources(sources)
    table: dict[str, dict[str, str]] = {}
    played: dict[str, dict[str, None]] = {}
    columns: list[str] = [] if by_control else list(agents)
    for pattern in sources:
        for path in files_of(pattern, root):
            data = read_results(path)
            row = table.setdefault(data["env_id"], {})
            for name in agents:
                if name not in data["agents"]:
                    continue
                episodes = (data["agents"][name]["episodes"], data["seed"])
                played.setdefault(data["env_id"], {})[episodes] = None
                column = name
                if by_control:
                    column = f"{name}, {control_label(data['env_kwargs'])}"
                    if column not in columns:
                        columns.append(column)
                if column in row:
                    raise ValueError(f"{path.name}: a second result for {data['env_id']}, "
                                     f"{column}")  # fmt: skip
                row[column] = percent(data["agents"][name])
    every = {pair for pairs in played.values() for pair in pairs}
    lead = ""
    if len(every) == 1:  # one line says it for every cell
        lead = f"Every cell on the same episodes: {episodes_text(*every.pop(), prose=True)}."
    else:
        columns.insert(0, "episodes (seed)")
        for env_id, pairs in played.items():
            table[env_id]["episodes (seed)"] = "; ".join(episodes_text(*p) for p in pairs)
    header = "| env | " + " | ".join(columns) + " |\n|---|" + "---|" * len(columns) + "\n"
    lines = [
        f"| `{env_id}` | " + " | ".join(row.get(column, "") for column in columns) + " |"
        for env_id, row in table.items()
    ]
    return header + "\n".join(lines) + sources_line(sources, style, root, lead)


def seeds_table(
    sources: dict[str, str], agents: list[str] | None = None, root: Path = ROOT, style: str = "page"
) -> str:
    """One row per agent of each summary over seeds (`benchmarks/experiments/baselines.py`): the
    runs' timesteps and median train time, and each agent's mean success on the test episodes over
    the seeds with its 95% t interval and the worst seed (the planners and random play the same
    episodes in every run), and a line naming those episodes and their seed. `agents` keeps
    those agents only."""
    _check_sources(sources)
    rows, notes, played = [], [], {}
    for pattern in sources:
        for path in files_of(pattern, root):
            data = _flat(path)
            played.update(dict.fromkeys(_test_episodes(data)))
            if "paired" in data:
                notes.append(_paired_line(data))
            for result in data["rows"]:
                if agents is not None and result["name"] not in agents:
                    continue
                rows.append(
                    f"| `{data['env_id']}` | {kwargs_text(data['env_kwargs'])} | "
                    f"{result['name']} | {len(data['seeds'])} | {data['timesteps']:,} | "
                    f"{train_minutes(data)} | {percent(result)} | {100 * result['worst']:.1f}% |"
                )
    header = (
        "| env | arguments | agent | seeds | timesteps | train min (median) | "
        "success, mean [95% CI] | worst seed |\n|---|---|---|---:|---:|---:|---|---:|\n"
    )
    lead = f"Every row on the same test episodes: {' and '.join(played)}." if played else ""
    return header + "\n".join(rows) + "".join(notes) + sources_line(sources, style, root, lead)


def ladder_seeds_table(sources: dict[str, str], root: Path = ROOT, style: str = "page") -> str:
    """Summaries over seeds (`benchmarks/experiments/baselines.py`) for comparing rungs and control
    modes at a glance, in two tables that fit the page. The learned agents, one row per summary:
    the env, its arguments, a short agent label (its other hyperparameters named in a note), the
    median train time, the best models' mean success with its 95% t interval and worst seed, and
    the seeds won and lost against the paired reference. The yardsticks, one row per env id:
    the planners, the paired reference and random in each control mode, on the same episodes."""
    _check_sources(sources)
    learned, overrides = [], []
    yardsticks: dict[str, dict[str, str]] = {}
    played: dict[str, None] = {}
    for path in (path for pattern in sources for path in files_of(pattern, root)):
        data = _flat(path)
        played.update(dict.fromkeys(_test_episodes(data)))
        learned.append(_learned_row(data))
        overrides += [k for k in data.get("hyperparams") or {} if k not in ("policy", *overrides)]
        row = yardsticks.setdefault(data["env_id"], {})
        for column, text in _yardsticks(data).items():
            if row.setdefault(column, text) != text:
                raise ValueError(f"{path.name}: {data['env_id']}'s {column} {text}, another "
                                 f"file's {row[column]}")  # fmt: skip
    note = "Agent: the learned agent and the policy its runs set"
    if overrides:
        named = ", ".join(f"`{key}`" for key in overrides)
        note += f"; their other hyperparameters ({named}) in the commands below"
    note += (
        ". Paired: against the reference on the same episodes, the seeds where the best model "
        "won and where it lost significantly (McNemar p < 0.05)."
    )
    columns = list(dict.fromkeys(column for row in yardsticks.values() for column in row))
    columns.sort(key=lambda column: column.startswith("random, "))  # random last
    lines = [
        "| env | arguments | agent | seeds x timesteps | train min (median) | "
        "success, mean [95% CI] | worst seed | paired (seeds) |",
        "|---|---|---|---:|---:|---|---:|---|",
        *learned,
        "",
        note,
        "",
        f"The yardsticks on the same test episodes{''.join(', ' + p for p in played)} (the "
        "planners in set-up control; random in each run's control mode, the mean of the runs' "
        "random agents, each drawing its actions from its run's seed):",
        "",
        "| env | " + " | ".join(columns) + " |",
        "|---|" + "---:|" * len(columns),
        *(f"| `{env_id}` | " + " | ".join(row.get(c, "") for c in columns) + " |"
          for env_id, row in yardsticks.items()),
    ]  # fmt: skip
    return "\n".join(lines) + sources_line(sources, style, root)


def _test_episodes(data: dict[str, Any]) -> list[str]:
    """A summary over seeds' test episodes in words (`episodes_text`: its rows' episodes, from
    its `test_seed`)."""
    return list(dict.fromkeys(
        episodes_text(row["episodes"], data.get("test_seed"), prose=True)
        for row in data["rows"] if "episodes" in row
    ))  # fmt: skip


def _learned_row(data: dict[str, Any]) -> str:
    """A summary's learned agent as a row of `ladder_seeds_table`: its best models over seeds,
    labelled by the agent's name and the policy its runs set."""
    best = next(row for row in data["rows"] if row["name"].endswith(" (best)"))
    agent = best["name"].removesuffix(" (best)")
    policy = (data.get("hyperparams") or {}).get("policy")
    return (
        f"| `{data['env_id']}` | {kwargs_text(data['env_kwargs'])} | "
        f"{agent + (f', {policy}' if policy else '')} | "
        f"{len(data['seeds'])} x {data['timesteps']:,} | {train_minutes(data)} | "
        f"{percent(best)} | {100 * best['worst']:.1f}% | {_paired_cell(data)} |"
    )


def _yardsticks(data: dict[str, Any]) -> dict[str, str]:
    """A summary's yardsticks by column: the planners, its paired reference (where it is not a
    planner) and random in the run's control mode."""
    rates = {row["name"]: row["success_rate"] for row in data["rows"]}
    found = {"greedy": rates["greedy planner"], "lookahead": rates["lookahead planner"]}
    paired = data.get("paired")
    if paired is not None and paired["reference"] not in found:
        found[paired["reference"]] = paired["reference_success_rate"]
    found[f"random, {control_label(data['env_kwargs'])}"] = rates["random"]
    return {column: f"{100 * rate:.1f}%" for column, rate in found.items()}


def _paired_cell(data: dict[str, Any]) -> str:
    """A summary's paired comparison in a few words: the reference, and on how many seeds the
    best model won and lost significantly (McNemar p < 0.05) on the same episodes."""
    paired = data.get("paired")
    if paired is None:
        return "-"
    significant = [row for row in paired["per_seed"] if row["mcnemar_p"] < 0.05]
    ahead = sum(row["wins"] > row["losses"] for row in significant)
    return f"{paired['reference']}: {ahead} ahead, {len(significant) - ahead} behind"


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


def planner_table(sources: dict[str, str], root: Path = ROOT, style: str = "page") -> str:
    """One row per planner and task of a planner benchmark (`benchmarks/speed/planners.py`): each
    implementation's decisions per second at each batch size on one core (the ratio to numpy's
    measured in the same run), the recorded decision states where it picks numpy's maneuver,
    and its success on the held-out episodes."""
    _check_sources(sources)
    blocks = []
    for pattern in sources:
        for path in files_of(pattern, root):
            rows = read_file(path)["rows"]
            first = rows[0]
            implementations = list(first["decisions_per_second"])
            batches = list(first["decisions_per_second"][implementations[0]])
            columns = [f"{i} batch {b}" for b in batches for i in implementations]
            columns += [f"{i} same choice" for i in first["agreement"]]
            columns += [f"{i} success" for i in first["success"]]
            lines = ["| planner | task | " + " | ".join(columns) + " |",
                     "|---|---|" + "---:|" * len(columns)]  # fmt: skip
            for row in rows:
                rates, cells = row["decisions_per_second"], []
                for batch in batches:
                    for implementation in implementations:
                        rate = rates[implementation][batch]
                        ratio = rate / rates["numpy"][batch]
                        cells.append(f"{rate:,.0f}" + ("" if implementation == "numpy"
                                                      else f" ({ratio:.1f}x)"))  # fmt: skip
                for a in row["agreement"].values():
                    cells.append(f"{a['same']:,} of {a['states']:,}")
                cells += [percent(result) for result in row["success"].values()]
                lines.append(f"| {row['planner']} | {row['task']} | " + " | ".join(cells) + " |")
            blocks.append("\n".join(lines))
    return "\n\n".join(blocks) + sources_line(sources, style, root)


def imitation_table(sources: dict[str, str], root: Path = ROOT, style: str = "page") -> str:
    """One row per picker of an imitation benchmark (`benchmarks/experiments/imitation.py`): how
    often its pick among the teacher's candidate aims is among the best on the held-out states, over
    all of them and where the goal itself is not among the best; the students' mean over network
    seeds with its 95% t interval."""
    _check_sources(sources)
    rows = []
    for pattern in sources:
        for path in files_of(pattern, root):
            data = read_file(path)
            setup, pickers = data["setup"], {}
            for row in data["rows"]:
                pickers[_picker(row)] = row
            for name, rates in pickers.items():
                rows.append(
                    f"| `{setup['env_id']}` | {setup['teacher']}, {setup['candidates']} | "
                    f"{setup['held_out']:,} of {setup['states']:,} | "
                    f"{100 * data['details']['detour_share']:.1f}% | {name} | "
                    f"{_rate_cell(rates['in_best'])} | {_rate_cell(rates['in_best_detour'])} |"
                )
    header = (
        "| env | teacher, candidates | held-out states | direct shot not among the best | picker | "
        "pick among the best | where a detour is needed |\n"
        "|---|---|---:|---:|---|---:|---:|\n"
    )
    return header + "\n".join(rows) + sources_line(sources, style, root)


def _picker(row: dict[str, Any]) -> str:
    """An imitation row's picker in words."""
    if row["picker"] == "goal":
        return "always the goal (the direct shot)"
    if row["picker"] == "random":
        return "a random candidate"
    return f"student: {row['features']}, {count(len(row['in_best']['seeds']), 'seed')}"


def _flat(path: Path) -> dict[str, Any]:
    """A results file's setup, details and rows as one mapping (a summary over seeds)."""
    data = read_file(path)
    return {**data["setup"], **data["details"], "rows": data["rows"]}


def fuzz_table(sources: dict[str, str], root: Path = ROOT, style: str = "page") -> str:
    """The public-API fuzz's findings (`benchmarks/validation/fuzz_navigate.py`): one row per class,
    and per results file the transitions with that finding among the single env's steps and among
    the vector env's transitions."""
    _check_sources(sources)
    runs = [(path, read_file(path)["details"]) for p in sources for path in files_of(p, root)]
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
    return "\n".join(rows) + sources_line(sources, style, root)


def cold_start_table(sources: dict[str, str], root: Path = ROOT, style: str = "page") -> str:
    """What a first run costs (`benchmarks/speed/cold_start.py`): per entry point, the seconds of
    its first call and of its whole process with an empty numba cache, on the revision measured and
    on the one it was measured against in the same run, and their ratio."""
    _check_sources(sources)
    rows = []
    for path in (path for p in sources for path in files_of(p, root)):
        data = read_file(path)
        against = data["setup"]["against"]
        rows.append(
            f"| entry | first call, s | process, s | first call at `{against}`, s | "
            f"process at `{against}`, s | process, ratio |\n|---|---:|---:|---:|---:|---:|"
        )
        for row in data["rows"]:
            name, trees = row["entry"], row["trees"]
            now, before = trees["this tree"], trees[against]
            rows.append(
                f"| {name} | {now['entry']:.1f} | {now['wall']:.1f} | {before['entry']:.1f} | "
                f"{before['wall']:.1f} | {now['wall'] / before['wall']:.2f} |"
            )
    return "\n".join(rows) + sources_line(sources, style, root)


def jax_agreement_table(sources: dict[str, str], root: Path = ROOT, style: str = "page") -> str:
    """TetherBounce's JAX kernel against its numba kernel (`benchmarks.validation.jax_agreement`):
    one row per dynamics, task and ranges, float64's worst difference (its field), the contacts
    given up (their worst), the changed outcomes, and float32's; under it the version of jax, the
    device, the commit and the wall time of each file."""
    _check_sources(sources)
    lines = [
        "| dynamics | task | ranges | cases | float64: worst (field) | given up (worst) | "
        "changed | float32: worst | changed (at a tether end) |",
        "|---|---|---|---:|---:|---:|---:|---:|---:|",
    ]
    notes = []
    for path in (path for p in sources for path in files_of(p, root)):
        data = read_file(path)
        cells: dict[tuple, dict[str, dict]] = {}
        for row in data["rows"]:
            key = (row["dynamics"], row["task"], row["ranges"])
            cells.setdefault(key, {})[row["precision"]] = row
        for (dynamics, task, ranges), by in cells.items():
            wide, narrow = by.get("float64"), by.get("float32")
            cases = (wide or narrow)["cases"]
            line = f"| {dynamics} | {task} | {ranges} | {cases:,} |"
            line += (
                f" {wide['outcome']:.1e} ({wide['outcome_field']}) | {wide['given_up']} "
                f"({wide['given_up_worst']:.1e}) | {wide['changed']} |"
                if wide
                else " - | - | - |"
            )
            line += (
                f" {narrow['outcome']:.1e} | {narrow['changed']} "
                f"({narrow['changed_at_tether_end']}) |"
                if narrow
                else " - | - |"
            )
            lines.append(line)
        notes.append(_run_line(data))
    return "\n".join(lines) + "\n\n" + " ".join(notes) + sources_line(sources, style, root)


def _cell(value: float | None, form: str) -> str:
    """A table cell: `value` formatted, "-" where it was not measured (None)."""
    return "-" if value is None else format(value, form)


def _timing_line(data: dict[str, Any]) -> str:
    """What ran a timing results file (`_run_line` with the device, its CPU, the precision and
    the timed blocks) and the machine's load before and after, without the final period."""
    details, machine, setup = data["details"], data["details"]["machine"], data["setup"]
    note = _run_line(data, {
        "device": f"{machine['device']} ({machine['cpu']}, {machine['cpu_count']} cores)",
        "precision": f"{setup['precision']}, the median of {setup['repeats']} timed blocks",
    }).rstrip(".")  # fmt: skip
    load = details.get("load_before"), details.get("load_after")
    if all(load):
        note += f"; the machine's load {load[0][0]:.1f} before, {load[1][0]:.1f} after"
    return note


def jax_throughput_table(sources: dict[str, str], root: Path = ROOT, style: str = "page") -> str:
    """Steps (TetherNavigate: maneuvers) per second, JAX against numba in one run
    (`benchmarks.speed.jax_throughput`): one row per dynamics (and control mode) and batch, and
    the ratio of the JAX scan to the numba vector env ("-" where a column was not measured);
    under it the machine and its load, the commit, and the first `jit`'s seconds with an empty
    and with a filled persistent compilation cache."""
    _check_sources(sources)
    lines = [
        "| dynamics | batch | JAX scan (steps/s) | JAX vector env | numba vector env | "
        "JAX scan / numba |",
        "|---|---:|---:|---:|---:|---:|",
    ]

    def rate(value) -> str:
        return "-" if value is None else f"{value:,.0f}"

    notes = []
    for path in (path for p in sources for path in files_of(p, root)):
        data = read_file(path)
        for row in data["rows"]:
            label = " ".join(row[key] for key in ("dynamics", "control") if key in row)
            scan, numba_vec = row["jax_scan"], row["numba_vec"]
            ratio = "-" if None in (scan, numba_vec) else f"{scan / numba_vec:.2f}"
            lines.append(
                f"| {label} | {row['batch']:,} | {rate(scan)} | {rate(row['jax_vec'])} | "
                f"{rate(numba_vec)} | {ratio} |"
            )
        details = data["details"]
        note = _timing_line(data)
        compiled = [
            f"{dynamics} {times['cold']['jit_s']:.1f} s ({times['cached']['jit_s']:.1f} s)"
            for dynamics, times in details.get("compile", {}).items()
        ]
        if compiled:
            batch = next(iter(details["compile"].values()))["batch"]
            note += (
                f". The first `jit` of the fused step at batch {batch:,}: "
                + ", ".join(compiled)
                + " (in brackets: with jax's persistent compilation cache filled)"
            )
        notes.append(note + ".")
    return "\n".join(lines) + "\n\n" + " ".join(notes) + sources_line(sources, style, root)


def jax_host_table(sources: dict[str, str], root: Path = ROOT, style: str = "page") -> str:
    """Steps (TetherNavigate: maneuvers) per second of the JAX envs' two kernels against the
    numba vector env in one run (`benchmarks.speed.jax_host`): one row per family, control
    mode, dynamics and batch, each JAX column's ratio to numba and its compile seconds ("-"
    where a kernel was not measured; the run's reasons under the table)."""
    _check_sources(sources)
    lines = [
        "| env | dynamics | batch | host kernel | XLA kernel | numba vector env | host / numba | "
        "XLA / numba | compile s (host, XLA) |",
        "|---|---|---:|---:|---:|---:|---:|---:|---|",
    ]

    def ratio(value) -> str:
        return _cell(value, ".2f" if value is None or value >= 0.01 else ".4f")

    notes = []
    for path in (path for p in sources for path in files_of(p, root)):
        data = read_file(path)
        for row in data["rows"]:
            env = row["family"] + (f" {row['control']}" if "control" in row else "")
            lines.append(
                f"| {env} | {row['dynamics']} | {row['batch']:,} | "
                f"{_cell(row['host_jax'], ',.0f')} | {_cell(row['xla_jax'], ',.0f')} | "
                f"{_cell(row['numba_vec'], ',.0f')} | "
                f"{ratio(row['host_over_numba'])} | {ratio(row['xla_over_numba'])} | "
                f"{row['host_compile_s']:.1f}, {_cell(row['xla_compile_s'], '.1f')} |"
            )
        details = data["details"]
        note = _timing_line(data)
        reasons = sorted(set(details.get("skipped", {}).values()))
        if reasons:
            note += ". XLA kernel not measured where " + "; ".join(reasons)
        notes.append(note + ".")
    return "\n".join(lines) + "\n\n" + " ".join(notes) + sources_line(sources, style, root)


def jax_navigate_agreement_table(
    sources: dict[str, str], root: Path = ROOT, style: str = "page"
) -> str:
    """TetherNavigate's JAX kernel against numba's in float64
    (`benchmarks.validation.jax_navigate_agreement`): per dynamics x control over its ids, the
    cases, the worst difference of the outcome and of the observation where the outcome agrees,
    and the changed outcomes with their classes; the range ends (`variant`) in rows of their
    own, named in the control's cell."""
    _check_sources(sources)
    lines = [
        "| dynamics | control | ids | cases | worst outcome difference | worst observation "
        "difference | changed outcomes | fused multiply-adds |",
        "|---|---|---:|---:|---:|---:|---:|---|",
    ]
    notes = []
    for path in (path for p in sources for path in files_of(p, root)):
        data = read_file(path)
        cells: dict[tuple, list[dict[str, Any]]] = {}
        for row in data["rows"]:
            key = (row["dynamics"], row["control"], row.get("variant", "defaults"),
                   row.get("precision", "float64"), row["fma"])  # fmt: skip
            cells.setdefault(key, []).append(row)
        for (dynamics, control, variant, precision, fma), rows in cells.items():
            cases = sum(row["cases"] for row in rows)
            changed = sum(row["changed"] for row in rows)
            at = "" if variant == "defaults" else " at " + variant.replace(",", ", ")
            lines.append(
                f"| {dynamics} | {control} ({precision}){at} | {len(rows)} | {cases:,} | "
                f"{max(row['worst_outcome'] for row in rows):.1e} | "
                f"{max(row['worst_observation'] for row in rows):.1e} | {changed:,} "
                f"({100 * changed / cases:.2f}%) | {'on' if fma else 'off'} |"
            )
        notes.append(_run_line(data))
    return "\n".join(lines) + "\n\n" + " ".join(notes) + sources_line(sources, style, root)


def jax_train_table(sources: dict[str, str], root: Path = ROOT, style: str = "page") -> str:
    """PPO compiled with the JAX env (`benchmarks.experiments.jax_train`) beside SB3's row on
    the same test episodes: per trainer, its seeds x timesteps, wall time, steps/s and success
    (mean [95% CI], worst seed)."""
    _check_sources(sources)
    lines = [
        "| trainer | seeds x timesteps | wall time | steps/s | success [95% CI] | worst seed |",
        "|---|---|---:|---:|---|---:|",
    ]
    notes = []
    for path in (path for p in sources for path in files_of(p, root)):
        data = read_file(path)
        setup, details = data["setup"], data["details"]
        success = np.array([row["success"] for row in data["rows"]])
        low, high = t_interval(success)
        lines.append(
            f"| JAX PPO (one run, seeds under `vmap`) | {len(success)} x "
            f"{setup['timesteps_per_seed']:,} | {data['seconds']:,.0f} s | "
            f"{details['steps_per_second']:,} | {100 * success.mean():.1f}% "
            f"[{100 * low:.1f}, {100 * high:.1f}] | {100 * success.min():.1f}% |"
        )
        sb3 = details.get("sb3")
        if sb3:
            low, high = sb3["success_ci"]
            trained = sum(sb3["train_seconds"] or [0])
            lines.append(
                f"| SB3 PPO (`{sb3['file']}`, one seed after another) | {sb3['seeds']} x "
                f"{sb3['timesteps']:,} | {trained:,.0f} s of training | - | "
                f"{100 * sb3['success_mean']:.1f}% [{100 * low:.1f}, {100 * high:.1f}] | "
                f"{100 * sb3['worst']:.1f}% |"
            )
        notes.append(
            _run_line(data, {"device": setup["device"]}).rstrip(".")
            + f"; compiling {details['compile_seconds']:.0f} s, peak RSS "
            f"{details['peak_rss_mb']:,} MB; {setup['episodes']:,} test episodes (seed "
            f"{setup['test_seed']:,}), the same as SB3's final table."
        )
        machine = setup.get("machine", {})
        load = machine.get("load_average_at_end", [0.0])[0]
        if load > machine.get("cpus", load):
            notes.append(
                f"The machine's load average at the end of the JAX run was {load:.1f} on its "
                f"{machine['cpus']} CPUs (other jobs shared them): its steps/s and wall time "
                "are a loaded machine's."
            )
    return "\n".join(lines) + "\n\n" + " ".join(notes) + sources_line(sources, style, root)


def jax_vs_sb3_table(sources: dict[str, str], root: Path = ROOT, style: str = "page") -> str:
    """The JAX trainer and SB3 timed in one run (`benchmarks.experiments.jax_vs_sb3`): per
    command, its seeds x timesteps, wall time, steps/s and the success of its best and last
    policies on the same test episodes (mean [95% CI], worst seed)."""
    _check_sources(sources)
    lines = [
        "| env | trainer | seeds x timesteps | wall time | steps/s | best policy [95% CI] | "
        "worst seed | last policy [95% CI] |",
        "|---|---|---|---:|---:|---|---:|---|",
    ]
    notes = []
    for path in (path for p in sources for path in files_of(p, root)):
        data = read_file(path)
        for row in data["rows"]:
            best, last = row["best"], row["last"]
            best_cells = ["-", "-"] if best is None else [
                _rate_cell({"mean": best["success_mean"], "ci": best["success_ci"]}),
                f"{100 * best['worst']:.1f}%",
            ]  # fmt: skip
            cells = [
                f"`{data['setup']['env_id']}`",
                row["trainer"],
                f"{row['seeds']} x {row['timesteps']:,}",
                f"{row['wall_seconds']:,.0f} s",
                f"{row['steps_per_second']:,.0f}",
                *best_cells,
                _rate_cell({"mean": last["success_mean"], "ci": last["success_ci"]}),
            ]
            lines.append("| " + " | ".join(cells) + " |")
        jax, sb3 = data["rows"]
        details, setup = data["details"], data["setup"]
        notes.append(
            f"`{setup['env_id']}`: {jax['trainer']} is `{jax['command']}`, its "
            f"{count(jax['seeds'], 'seed')} in one process; "
            f"{sb3['trainer']} is `{sb3['command']}` for k = 0 .. {sb3['seeds'] - 1}, one seed "
            f"per process, one after another. Wall time is each command's, "
            f"start to exit (start-up, compiling, training, periodic evaluations, final table): "
            f"the JAX command's is {100 * details['wall_ratio']:.0f}% of the "
            f"{sb3['seeds']} SB3 commands'"
            + (
                f" ({sum(sb3['wall_seconds_per_seed'][:2]):,.0f} s for the first two)"
                if len(sb3.get("wall_seconds_per_seed", [])) > 2
                else ""
            )
            + _gap_sentence(details)
            + f". The JAX run compiled for "
            f"{jax['compile_seconds']:.0f} s and peaked at {jax['peak_rss_mb']:,} MB of RSS. "
            f"Each policy played the final table's test episodes (seed "
            f"{setup['test_seed']:,}) on the numba env. Load average "
            f"{details['load_before'][0]:.1f} before and {details['load_after'][0]:.1f} after, "
            f"on {setup['cpus']} CPUs. " + _run_line(data)
        )
    return "\n".join(lines) + "\n\n" + " ".join(notes) + sources_line(sources, style, root)


def _gap_sentence(details: dict[str, Any]) -> str:
    """The JAX mean minus SB3's over their seeds, its 95% interval and Welch's p
    (`statistics.seeds_difference`), where the file has it ("" where not)."""
    kind, gap = next(((name.rsplit("_", 1)[1], value) for name, value in details.items()
                      if name.startswith("jax_minus_sb3_")), (None, None))  # fmt: skip
    if gap is None:
        return ""
    said = f"; the JAX mean minus SB3's ({kind} policies) is {100 * gap['difference']:+.1f} points"
    if np.isnan(gap["p"]):
        return said + " (one seed on a side: no interval, no test)"
    low, high = (100 * bound for bound in gap["ci"])
    return f"{said}, 95% CI [{low:+.1f}, {high:+.1f}], Welch's p = {gap['p']:.2f}"


def _run_line(data: dict[str, Any], shown: dict[str, str] | None = None) -> str:
    """What ran a results file: jax's version, the device (and the `shown` parts: "device",
    "precision"), the commit, the wall time."""
    shown = {"device": data["details"].get("device"), **(shown or {})}
    parts = [f"jax {data['environment']['jax']}"] if "jax" in data["environment"] else []
    parts += [shown[key] for key in ("device", "precision") if shown.get(key)]
    if data["commit"]:
        parts.append(f"commit `{data['commit'][:7]}`" + (" (with changes)" * bool(data["dirty"])))
    if data["seconds"] is not None:
        parts.append(f"{data['seconds']:,.0f} s")
    return "Run: " + ", ".join(parts) + "."


def open_challenge_table(sources: dict[str, str], root: Path = ROOT, style: str = "page") -> str:
    """An aim recipe trained several times longer on the JAX backend
    (`benchmarks/experiments/open_challenge.py`): per agent, the success on the test episodes and
    how its actions rank on the aim search's states (aims off the goal, actions among the
    search's best, and among the best where a detour is needed), PPO's over seeds (mean [95%
    CI], worst seed)."""
    _check_sources(sources)
    lines = [
        "| env | agent | seeds x timesteps | success [95% CI] | worst seed | aims off the goal "
        "| among the best | where a detour is needed |",
        "|---|---|---|---|---:|---:|---:|---:|",
    ]
    notes = []
    for path in (path for p in sources for path in files_of(p, root)):
        data = read_file(path)
        setup, details = data["setup"], data["details"]
        for row in data["rows"]:
            measures = [_rate_cell(row[m]) for m in ("off_goal", "in_best", "in_best_detour")]
            if "success" in row:
                success = row["success"]
                trained = [
                    f"{row['seeds']} x {row['timesteps']:,}",
                    _rate_cell({"mean": success["success_mean"], "ci": success["success_ci"]}),
                    f"{100 * success['worst']:.1f}%",
                ]
            else:
                trained = ["-", "-", "-"]
            lines.append(f"| `{setup['env_id']}` | {row['agent']} | " + " | ".join(
                [*trained, *measures]) + " |")  # fmt: skip
        wall = details["train_wall_seconds"]
        notes.append(
            f"`{setup['env_id']}`: {setup['times']:g} times the recipe's "
            f"{setup['recipe_timesteps']:,} timesteps per seed, "
            + ("" if wall is None else f"trained in {wall:,.0f} s of wall time ")
            + f"({details['steps_per_second']:,.0f} maneuvers/s over the seeds); the actions "
            f"ranked on {setup['states']:,} states the aim search meets (seed "
            f"{setup['states_seed']:,}), {100 * details['detour_share']:.1f}% of them needing a "
            f"detour; an aim is off the goal beyond {setup['off_goal_m']} m."
        )
    return "\n".join(lines) + "\n\n" + " ".join(notes) + sources_line(sources, style, root)


def _rate_cell(rate: float | dict[str, Any]) -> str:
    """A rate as a percentage, or a mean over seeds with its 95% interval."""
    if not isinstance(rate, dict):
        return f"{100 * rate:.1f}%"
    low, high = rate["ci"]
    return f"{100 * rate['mean']:.1f}% [{100 * low:.1f}, {100 * high:.1f}]"


def datasets_table(sources: dict[str, str], root: Path = ROOT, style: str = "page") -> str:
    """The offline datasets (`benchmarks/experiments/datasets.py`): per dataset, its collector,
    episodes, maneuvers, the collector's success on the test episodes, its size on disk and the
    seconds it took to make (wall, and the CPU's)."""
    _check_sources(sources)
    lines = [
        "| dataset | collector | episodes | maneuvers | collector's success [95% CI] | "
        "disk | seconds (CPU) |",
        "|---|---|---:|---:|---|---:|---:|",
    ]
    notes = []
    for path in (path for p in sources for path in files_of(p, root)):
        data = read_file(path)
        setup = data["setup"]
        for row in data["rows"]:
            lines.append(
                f"| `{row['dataset_id']}` | {row['collector']} | {row['episodes']:,} | "
                f"{row['maneuvers']:,} | {percent(row)} | {row['disk_mb']:,.1f} MB | "
                f"{row['seconds']:,.0f} ({row['cpu_seconds']:,.0f}) |"
            )
        start, end = setup["load_average_at_start"][0], setup["load_average_at_end"][0]
        notes.append(
            f"At least {setup['maneuvers']:,} maneuvers of whole episodes per dataset; the "
            f"collector's success on the {setup['test_episodes']:,} test episodes (seed "
            f"{setup['test_seed']:,}) of the tables above. Load average {start:.1f} at the "
            f"start and {end:.1f} at the end on {setup['cpus']} CPUs (the wall time is a shared "
            f"machine's). " + _run_line(data)
        )
    return "\n".join(lines) + "\n\n" + " ".join(notes) + sources_line(sources, style, root)


def offline_table(sources: dict[str, str], root: Path = ROOT, style: str = "page") -> str:
    """The offline baselines (`benchmarks/experiments/offline.py`): per rung, dataset and
    algorithm, the success over seeds (mean [95% t interval], worst seed) beside the dataset's
    collector, the mean training seconds, and for aim control the detour probe's measures."""
    _check_sources(sources)
    lines = [
        "| rung | dataset (quality-control) | algorithm | success [95% CI] | worst seed | "
        "collector | train s | aims off the goal | among the best where a detour is needed |",
        "|---|---|---|---|---:|---:|---:|---:|---:|",
    ]

    def share(row: dict[str, Any], key: str) -> str:
        return f"{100 * row[key]:.1f}%" if key in row else "-"

    notes = []
    for path in (path for p in sources for path in files_of(p, root)):
        data = read_file(path)
        setup, details = data["setup"], data["details"]
        for row in details["summary"]:
            ci = row["success_ci"]
            interval = "" if ci is None else f" [{100 * ci[0]:.1f}, {100 * ci[1]:.1f}]"
            lines.append(
                f"| {row['rung']} | {row['quality']}-{row['control']} | {row['algo'].upper()} | "
                f"{100 * row['success_mean']:.1f}%{interval} | {100 * row['worst']:.1f}% | "
                f"{100 * row['collector_success']:.1f}% ({row['collector']}) | "
                f"{row['train_seconds_mean']:,.0f} | {share(row, 'off_goal')} | "
                f"{share(row, 'in_best_detour')} |"
            )
        for env_id, yardsticks in details.get("probe_yardsticks", {}).items():
            lines.extend(
                f"| {env_id.removeprefix('TetherNavigate_')} | (yardstick) | {name} | | | | | "
                f"{share(measures, 'off_goal')} | {share(measures, 'in_best_detour')} |"
                for name, measures in yardsticks.items()
            )
        start, end = setup["load_average_at_start"][0], setup["load_average_at_end"][0]
        steps = setup["gradient_steps"] or "the zoo entry's"
        notes.append(
            f"{len(setup['seeds'])} seeds each; datasets of at least {setup['maneuvers']:,} "
            f"maneuvers; {steps} gradient steps on one torch thread; every policy on the "
            f"{setup['test_episodes']:,} test episodes (seed {setup['test_seed']:,}); the "
            f"aim-control policies probed on {details['probe_states']:,} states. Load average "
            f"{start:.1f} at the start and {end:.1f} at the end on {setup['cpus']} CPUs. "
            + _run_line(data)
        )
    return "\n".join(lines) + "\n\n" + " ".join(notes) + sources_line(sources, style, root)


def ladder_ids() -> str:
    """TetherNavigate's ladder: each registered id and its arguments, from `tether_gym.ladder`."""
    from tether_gym import ladder

    lines = ["| id | arguments |", "|---|---|"]
    for env_id, kwargs in ladder.ids().items():
        shown = {k: ("the Wall map" if v == ladder.WALL else v) for k, v in kwargs.items()}
        lines.append(f"| `{env_id}` | {kwargs_text(shown)} |")
    return "\n".join(lines) + "\n"


def jax_per_thread_table(sources: dict[str, str], root: Path = ROOT, style: str = "page") -> str:
    """TetherNavigate's XLA kernel per thread against the numba kernel, and against the XLA
    kernel of an earlier commit in the same run (`benchmarks.speed.jax_per_thread`): one row per
    build and batch, microseconds of one CPU per maneuver, XLA's ratios to numba and to the
    earlier kernel, the compile seconds, and the issue's target where it sets one (at batch
    1,024)."""
    _check_sources(sources)
    lines = [
        "| build | batch | numba us | before us | XLA us | XLA / numba | XLA / before | "
        "compile s | target |",
        "|---|---:|---:|---:|---:|---:|---:|---|---:|",
    ]
    notes = []
    for path in (path for p in sources for path in files_of(p, root)):
        data = read_file(path)
        targets = data["setup"]["targets"]
        for row in data["rows"]:
            build = f"{row['dynamics']} {row['control']}"
            target = targets.get(build) if row["batch"] == 1024 else None
            lines.append(
                f"| {build} | {row['batch']:,} | {row['numba_us']:,.1f} | "
                f"{_cell(row.get('base_us'), ',.0f')} | {row['xla_us']:,.0f} | "
                f"{row['xla_over_numba']:.1f} | "
                f"{_cell(row.get('new_over_base'), '.2f')} | "
                f"{_cell(row.get('base_compile_s'), '.0f')}, {row['compile_s']:.0f} | "
                f"{_cell(target, 'g')}{'' if target is None else 'x'} |"
            )
        against, cap = data["setup"]["against"], data["setup"].get("max_contact_steps")
        note = _timing_line(data)
        if cap:
            note += (f"; hybrid contacts capped at {cap:,} RK4 steps on both sides "
                     "(`--max-contact-steps`: cost only, capped outcomes change)")  # fmt: skip
        if against:
            note += (f"; before: commit `{against}`'s XLA kernel, measured in the same run "
                     "(compile s: before, then XLA)")  # fmt: skip
        notes.append(note + ".")
    return "\n".join(lines) + "\n\n" + " ".join(notes) + sources_line(sources, style, root)
