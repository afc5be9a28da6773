"""The documentation site: its code blocks run, its results tables come from the results
files, it builds with --strict, and a headless Chromium shows its pages with no console error.
"""

from __future__ import annotations

import contextlib
import functools
import html
import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.helpers import ROOT
from tests.helpers.docblocks import RUNS, blocks, budget, commands

DOCS = ROOT / "docs"
PAGES = sorted(p for p in DOCS.rglob("*.md") if "figures" not in p.parts)
BLOCKS = [b for page in [*PAGES, ROOT / "README.md"] for b in blocks(page)]
SCREENSHOTS = ROOT / "build" / "screenshots"


if str(DOCS) not in sys.path:  # the docs' modules, as docs/hooks.py finds them
    sys.path.insert(0, str(DOCS))

from docgen import cli_reference, docstring_tables, macros, readme, results, tables  # noqa: E402

from tether_gym.evaluation import results_file  # noqa: E402


def _entry_point(program: str):
    return cli_reference.entry_point(program)


# --- code blocks ---------------------------------------------------------------------------


def test_every_block_runs_or_says_why_not():
    assert BLOCKS, "no code block found"
    for block in BLOCKS:
        assert block.language in RUNS or block.not_run, (
            f"{block.id}: a ```{block.language} block: make it python or bash, or mark it "
            "<!-- not run: reason -->"
        )
        if block.language == "bash" and not block.not_run:
            for words in commands(block.code):
                budget(words)  # ValueError for a program the tests cannot run


PYTHON = [b for b in BLOCKS if b.language == "python" and not b.not_run]
BASH = [b for b in BLOCKS if b.language == "bash" and not b.not_run]


TRAINS = (".learn(", "train(")
"""A Python block that trains runs among the slow tests."""


@pytest.mark.parametrize(
    "block",
    [pytest.param(b, marks=pytest.mark.slow) if any(t in b.code for t in TRAINS) else b
     for b in PYTHON],
    ids=[b.id for b in PYTHON],
)  # fmt: skip
def test_python_block_runs(block, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    exec(compile(block.code, f"{block.path}:{block.line}", "exec"), {"__name__": "__main__"})
    assert capsys.readouterr().out.strip(), f"{block.id} printed nothing"


@pytest.mark.slow
@pytest.mark.parametrize("block", BASH, ids=[b.id for b in BASH])
@pytest.mark.filterwarnings("ignore:You have specified a mini-batch size:UserWarning")
def test_bash_block_runs(block, tmp_path, monkeypatch):
    """Each command of the block, in order in one folder, with a small budget (`budget`: its 4
    envs make a PPO rollout shorter than the recipes' mini-batch, which SB3 warns of)."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    for words in commands(block.code):
        program, argv = budget(words)
        for i, word in enumerate(argv[:-1]):  # output files go into the block's folder
            if word in ("--out", "--json", "--csv", "--plot") and "." in Path(argv[i + 1]).name:
                Path(argv[i + 1]).parent.mkdir(parents=True, exist_ok=True)
        try:
            status = _entry_point(program)(argv)
        except SystemExit as stop:
            status = stop.code
        assert status in (None, 0), f"{block.id}: {' '.join(words)} exited with {status}"


# --- results tables ------------------------------------------------------------------------

SOURCES = [*PAGES, ROOT / "README.md"]


def _calls(page: Path) -> list[str]:
    """The placeholders of a page, and the README's generated blocks."""
    text = page.read_text()
    return [*macros.PLACEHOLDER.findall(text), *(m[1] for m in readme.README_BLOCK.findall(text))]


CALLS = [(page, call) for page in SOURCES for call in _calls(page)]
RESULTS_CALLS = [(p, c) for p, c in CALLS if macros.parse_call(c)[0] in macros.RESULTS_MACROS]


RESULTS_PAGES = {page for page, _ in RESULTS_CALLS if page.is_relative_to(DOCS)}
"""The pages that show results tables: every table on them fits the page at 1280 px."""


def test_the_docs_show_results_tables():
    assert any(p.name == "results.md" for p, _ in RESULTS_CALLS)
    assert any(p.name == "README.md" for p, _ in RESULTS_CALLS)


@pytest.mark.parametrize("page, call", CALLS, ids=[f"{p.name}:{c[:40]}" for p, c in CALLS])
def test_placeholder_renders(page, call):
    assert macros.expand(call).strip()


def test_every_family_has_its_reference_on_a_page_of_the_nav():
    """Each env family's page in the site's nav shows its record (`family_reference`), so an env
    added to `tether_gym.families` is missing from the docs only by a failing test."""
    from tether_gym.families import FAMILIES

    nav = (ROOT / "mkdocs.yml").read_text()
    for env_family in FAMILIES:
        call = f'family_reference("{env_family.name}")'
        pages = [p for p, c in CALLS if c == call]
        assert pages, f"no page calls {call}"
        assert all(str(p.relative_to(DOCS)) in nav for p in pages), pages


def _change(path: Path) -> str:
    """Set the first success rate (an imitation benchmark's: always-goal's) of a results file to
    0.123456, a fuzz's first count to 123456, a cold start's first time to 123456 s, or the jax
    agreement's first cases (the throughput's first JAX rate, the per-thread table's first XLA
    cost) to 123456: what the table then shows."""
    if path.suffix == ".json" and "holes" in (data := json.loads(path.read_text()))["details"]:
        details = data["details"]  # benchmarks/validation/fuzz_navigate.py
        details["counts"]["single"]["counts"][details["holes"][0]] = 123456
        path.write_text(json.dumps(data))
        return "123,456"
    if path.suffix == ".md":
        text = path.read_text()
        text, n = re.subn(r"success_rate: [0-9.]+", "success_rate: 0.123456", text, count=1)
        assert n == 1
        path.write_text(text)
        return "12.3%"
    data = json.loads(path.read_text())
    first = data["rows"][0]
    if "trees" in first:  # benchmarks/speed/cold_start.py: the first entry's process seconds
        first["trees"]["this tree"]["wall"] = 123456.0
        path.write_text(json.dumps(data))
        return "123456.0"
    if "outcome_field" in first or "jax_scan" in first:  # the jax agreement and throughput
        first["cases" if "outcome_field" in first else "jax_scan"] = 123456
        path.write_text(json.dumps(data))
        return "123,456"
    if "host_jax" in first:  # benchmarks/speed/jax_host.py: the first host-kernel rate
        first["host_jax"] = 123456
        path.write_text(json.dumps(data))
        return "123,456"
    if "xla_us" in first:  # benchmarks/speed/jax_per_thread.py: the first XLA cost
        first["xla_us"] = 123456.0
        path.write_text(json.dumps(data))
        return "123,456"
    if "worst_outcome" in first:  # benchmarks/validation/jax_navigate_agreement.py: the worst
        first["worst_outcome"] = 123456.0
        path.write_text(json.dumps(data))
        return "1.2e+05"
    if "rollout_success_last" in first:  # benchmarks/experiments/jax_train.py: the worst seed
        first["success"] = 0.123456
    elif "trainer" in first:  # benchmarks/experiments/jax_vs_sb3.py: the best policies' mean
        first["best"]["success_mean"] = 0.123456
    elif "decisions_per_second" in first:  # benchmarks/speed/planners.py
        next(iter(first["success"].values()))["success_rate"] = 0.123456
    elif "picker" in first:  # benchmarks/experiments/imitation.py: always the goal
        first["in_best"] = 0.123456
    elif "off_goal" in first:  # benchmarks/experiments/open_challenge.py: the direct shot
        first["off_goal"] = 0.123456
    elif "gradient_steps" in first:  # benchmarks/experiments/offline.py: the first summary's
        data["details"]["summary"][0]["success_mean"] = 0.123456
    else:
        first["success_rate"] = 0.123456
    path.write_text(json.dumps(data))
    return "12.3%"


@pytest.mark.parametrize(
    "page, call", RESULTS_CALLS, ids=[f"{p.name}:{c[:40]}" for p, c in RESULTS_CALLS]
)
def test_results_table_renders_from_its_files(page, call, tmp_path):
    """The table is its files': the same files elsewhere give the same table, and changing a
    file's number changes the table."""
    _, args, _ = macros.parse_call(call)
    sources = args[0]
    assert all(command.strip() for command in sources.values())
    files = [f for pattern in sources for f in results.files_of(pattern, ROOT)]
    for file in files:
        copy = tmp_path / file.relative_to(ROOT)
        copy.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(file, copy)
    table = macros.expand(call)
    assert macros.expand(call, tmp_path) == table
    marks = {_change(results.files_of(pattern, tmp_path)[0]) for pattern in sources}
    assert not any(mark in table for mark in marks)
    changed = macros.expand(call, tmp_path)
    assert changed != table and all(mark in changed for mark in marks)
    unfolded = " ".join(table.replace("\\\n", " ").split())  # the note's commands, unfolded
    for command in sources.values():  # as a shell reads it (quoted where the file has not)
        shown = " ".join(tables.shell_command(command).split())
        assert shown in unfolded, "the table names the command that writes it"


def test_no_results_table_is_typed_by_hand():
    """A table row in a page's source with a percentage is a number typed by hand (the
    README's generated blocks left out)."""
    for page in SOURCES:
        text = readme.README_BLOCK.sub("", page.read_text())
        for number, line in enumerate(text.splitlines(), 1):
            assert not re.match(r"\s*\|.*\d(\.\d+)?%", line), f"{page.name}:{number}: {line}"


def test_readme_table_is_fresh():
    text = (ROOT / "README.md").read_text()
    assert readme.readme_text(text) == text, "stale: python docs/hooks.py --readme"


RESULTS_FILES = sorted((ROOT / "results").rglob("*.json"))


@pytest.mark.parametrize("path", RESULTS_FILES, ids=[p.relative_to(ROOT).as_posix()
                                                      for p in RESULTS_FILES])  # fmt: skip
def test_every_results_file_has_the_schema(path):
    """One schema (`tether_gym.evaluation.results_file`): the same top-level keys in every
    file, a command that names where it comes from."""
    data = results_file.read(path)
    assert tuple(data) == results_file.KEYS
    assert data["command"].split()[0] in ("python", "tether-evaluate"), data["command"]


def test_a_results_file_without_its_command_is_refused():
    with pytest.raises(ValueError, match="command"):
        tables.success_table({"results/ladder/*.json": " "})
    with pytest.raises(ValueError, match="no results file"):
        tables.success_table({"results/none/*.json": "true"})


# --- the site ------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("site")
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    done = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--quiet", "--site-dir", str(out)],
        cwd=ROOT, capture_output=True, text=True, env=env, timeout=300,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    return out


def test_site_builds_with_the_results_and_the_specs(site):
    results = (site / "results" / "index.html").read_text()
    data = json.loads((ROOT / "results/ladder/TetherNavigate_OpenReach-v2_setup.json").read_text())
    greedy = next(r for r in data["rows"] if r["name"] == "greedy")
    assert f"{100 * greedy['success_rate']:.1f}%" in results
    bounce = (site / "envs" / "tether-bounce" / "index.html").read_text()
    assert "Action Space" in bounce and "tether_bounce.gif" in bounce  # the env's docstring
    training = (site / "training" / "index.html").read_text()
    assert "--hyperparams" in training and "--env-kwargs" in training  # the CLI's own help


# What a page shows of its tables, at 1280 px: each table's header and first column, what is
# wrong with its layout (cut off, clipped, scrolling without a scrollbar, an id broken), and
# whether it is wider than its box and scrolls (`wide`).
TABLES_JS = r"""(() => {
  const text = e => e.textContent.replace(/\s+/g, ' ').trim();
  const view = document.documentElement.clientWidth;
  return [...document.querySelectorAll('article table')].map(table => {
    const rows = [...table.rows];
    const head = rows.length && rows[0].querySelector('th') ? rows.shift() : null;
    const problems = [];
    let box = table, wide = null;
    for (let e = table; e && e !== document.documentElement; e = e.parentElement) {
      if (e.scrollWidth <= e.clientWidth + 1) continue;
      const style = getComputedStyle(e);
      if (style.overflowX === 'visible') continue;
      if (style.overflowX === 'auto' || style.overflowX === 'scroll') {
        wide = `${e.scrollWidth} px wide in a scrolling box of ${e.clientWidth} px`;
        const bar = e.offsetHeight - e.clientHeight - parseFloat(style.borderTopWidth)
          - parseFloat(style.borderBottomWidth);
        if (bar < 6 || style.scrollbarWidth === 'none')
          problems.push('scrolls sideways with no scrollbar to show it');
      } else {
        problems.push(`cut off: ${e.scrollWidth} px wide in a box of ${e.clientWidth} px`);
      }
      box = e;
      break;
    }
    const r = box.getBoundingClientRect();
    if (r.right > view + 1 || r.left < -1) problems.push(`beyond the page: ${r.left}..${r.right}`);
    for (const cell of table.querySelectorAll('th, td')) {
      const style = getComputedStyle(cell);
      if (style.overflowX !== 'visible' && cell.scrollWidth > cell.clientWidth + 1)
        problems.push(`a clipped cell: ${text(cell).slice(0, 40)}`);
    }
    for (const code of table.querySelectorAll('code')) {
      if (!/\s/.test(code.textContent) && code.getClientRects().length > 1)
        problems.push(`broken mid-word: ${code.textContent}`);
    }
    return {head: head ? [...head.cells].map(text) : [],
            first: rows.map(row => row.cells.length ? text(row.cells[0]) : ''),
            problems, wide};
  });
})()"""


def _plain(cell: str) -> str:
    """A Markdown cell's text as the page shows it: code spans, emphasis, links undone."""
    cell = re.sub(r"\[([^]]*)\]\([^)]*\)", r"\1", cell.replace("\\|", "|"))
    parts = re.split(r"(`[^`]*`)", cell)
    text = "".join(p[1:-1] if p.startswith("`") else p.replace("*", "") for p in parts)
    return " ".join(html.unescape(text).split())


def _tables(markdown: str) -> list[tuple[list[str], list[str]]]:
    """Each Markdown table's header and first column, one entry per row: a row with an empty
    first cell continues the row above it (the docstrings' wrapped entries)."""
    lines, found = markdown.splitlines(), []
    for i, line in enumerate(lines[:-1]):
        if not (
            line.strip().startswith("|") and re.match(r"^\s*\|[\s:|-]*-[\s:|-]*$", lines[i + 1])
        ):
            continue

        def cells(row):
            return [c.strip() for c in re.split(r"(?<!\\)\|", row.strip()[1:-1])]

        first = []
        for row in lines[i + 2 :]:
            if not row.strip().startswith("|"):
                break
            if cells(row)[0] or not first:
                first.append(_plain(cells(row)[0]))
        found.append(([_plain(c) for c in cells(line)], first))
    return found


def _docstrings(identifier: str, options: str) -> list[str]:
    """The docstrings a `::: identifier` block shows: its own and its members' (all public
    ones, or those `members:` lists; none with `members: false`)."""
    import griffe

    package = _griffe()
    obj = package[identifier.removeprefix("tether_gym.")] if "." in identifier else package
    listed = re.search(r"members:\s*(\[.*?\]|false)", options)
    names = None if listed is None else re.findall(r"\w+", listed[1].replace("false", ""))
    found = [obj.docstring.value] if obj.docstring else []
    stack = [m for n, m in obj.members.items() if names is None or n in names]
    while stack:
        member = stack.pop()
        if member.is_alias or member.name.startswith("_"):
            continue
        if member.docstring:
            found.append(member.docstring.value)
        if names is None and isinstance(member, griffe.Class | griffe.Module):
            stack += member.members.values()
    return found


@functools.cache
def _griffe():
    import griffe

    return griffe.load("tether_gym", search_paths=[str(ROOT)])


def _source_tables(page: Path) -> list[tuple[list[str], list[str]]]:
    """The tables a page's source makes: its own, its placeholders', its snippets' and the
    docstrings' of its `:::` blocks."""
    text = re.sub(r'^--8<-- "(.+)"$', lambda m: (ROOT / m[1]).read_text(), page.read_text(),
                  flags=re.MULTILINE)  # fmt: skip
    text = macros.render(text)
    found = _tables(text)
    for identifier, options in re.findall(r"^::: (\S+)\n((?:    .*\n)*)", text, re.MULTILINE):
        for docstring in _docstrings(identifier, options):
            found += _tables(docstring)
    return found


@pytest.mark.slow
def test_chromium_shows_the_site(site):
    """Every page of the built site in a headless Chromium 1280 px wide: no console error, no
    table cut off (wider than its box with no scrolling wrapper, a scrollbar not shown, a cell
    clipped, an id broken mid-word), on the pages that show results no table wider than its
    box even where it scrolls, and every table of its source (the page's, the results
    files', the command-line help's, the docstrings') shown with one row per entry, neither
    split nor merged; the home and env pages with their GIFs. Screenshots in
    build/screenshots/: the env pages' action tables, Training and Results."""
    from tests.helpers import browser

    executable = browser.chromium()
    required = os.environ.get("TETHER_REQUIRE_CHROMIUM") == "1"
    if executable is None or importlib.util.find_spec("websocket") is None:
        reason = "no chromium (apt-get install chromium) or no websocket-client (docs extra)"
        if required:
            pytest.fail(reason)
        pytest.skip(reason)
    SCREENSHOTS.mkdir(parents=True, exist_ok=True)
    pages = sorted(p.parent.relative_to(site).as_posix() for p in site.rglob("index.html"))
    pages = [("" if p == "." else p + "/") for p in pages if not p.startswith(("assets", "search"))]
    assert len(pages) >= len(PAGES) - 1, pages
    problems, checked = [], 0
    chrome = browser.Browser(executable, width=1280, height=900)
    try:
        with browser.serve(site) as base:
            for url in pages:
                chrome.open(base + url)
                name = url or "home"
                if chrome.errors():
                    problems.append(f"{name}: console errors {chrome.errors()}")
                title = chrome.evaluate("document.querySelector('article h1').textContent")
                assert title and "404" not in title, url
                shown = chrome.evaluate(TABLES_JS)
                source = DOCS / (url.rstrip("/") or "index")
                source = source.with_suffix(".md") if source.with_suffix(".md").exists() else (
                    source / "index.md")  # fmt: skip
                for i, table in enumerate(shown):
                    found = table["problems"]
                    if source in RESULTS_PAGES and table["wide"]:
                        found = [*found, table["wide"]]  # a results page's tables fit its width
                    problems += [f"{name} table {i + 1} {table['head']}: {p}" for p in found]
                unmatched = list(shown)
                for head, first in _source_tables(source) if source.exists() else []:
                    checked += 1
                    twin = next((t for t in unmatched if (t["head"], t["first"]) == (head, first)),
                                None)  # fmt: skip
                    if twin is not None:
                        unmatched.remove(twin)
                        continue
                    counts = [len(t["first"]) for t in shown if t["head"] == head]
                    problems.append(
                        f"{name}: the table {head} has {len(first)} rows in its "
                        f"source, the page shows {counts or 'no such table'}"
                    )
                if url in ("", "envs/tether-bounce/"):
                    gifs = [i for i in chrome.images() if i["src"].endswith(".gif")]
                    assert gifs, f"{name}: no GIF"
                    for gif in gifs:
                        assert gif["complete"] and gif["width"] >= 640, gif
                if url.startswith("envs/"):
                    env = "tether_gym.envs." + (
                        "TetherBounceEnv"
                        if "bounce" in url
                        else "tether_navigate.TetherNavigateEnv"
                    )
                    chrome.screenshot(SCREENSHOTS / f"{url.split('/')[1]}-action-space.png",
                                      between=(f"[id='{env}--action-space']",
                                               f"[id='{env}--observation-space']"))  # fmt: skip
                if url in ("training/", "results/", ""):
                    chrome.screenshot(SCREENSHOTS / f"{name.strip('/')}.png", full=True)
    finally:
        with contextlib.suppress(Exception):
            chrome.close()
    assert not problems, "\n".join(dict.fromkeys(problems))
    assert checked >= 40, f"only {checked} tables found in the pages' sources"


BASELINES = "python -m benchmarks.experiments.baselines"
IMITATION = "python -m benchmarks.experiments.imitation"


def _results(rows: list[dict], setup: dict, details: dict | None = None) -> str:
    """A results file's text (the schema) with these parts."""
    return json.dumps({"command": "python -m benchmarks.experiments.x", "commit": None,
                       "dirty": None, "environment": {}, "seconds": None, "setup": setup,
                       "rows": rows, "details": details or {}})  # fmt: skip


def test_a_success_table_shows_maneuvers_only_where_its_files_record_them(tmp_path):
    """The maneuvers column where a row has them, `-` on the rows without; no column where no
    file records them (a model card, a TetherBounce file). The episodes with their seed, and
    the interval from the successes where the file records none."""
    setup = {"env_id": "TetherNavigate_OpenReach-v3", "env_kwargs": {}, "seed": 0}
    row = {"name": "greedy", "episodes": 10, "success_rate": 0.5}
    (tmp_path / "a.json").write_text(_results([row], setup))
    (tmp_path / "b.json").write_text(_results([{**row, "maneuvers_mean": 2.346}], setup))
    without = tables.success_table({"a.json": "tether-evaluate"}, root=tmp_path).splitlines()
    assert without[0] == "| env | arguments | agent | episodes (seed) | success [95% CI] |"
    assert without[2] == (
        "| `TetherNavigate_OpenReach-v3` | defaults | greedy | 10 (seed 0) | 50.0% [23.7, 76.3] |"
    )
    both = tables.success_table({"*.json": "tether-evaluate"}, root=tmp_path).splitlines()
    assert both[0].endswith("| success [95% CI] | maneuvers to goal |")
    assert [line.rsplit("|", 2)[1].strip() for line in both[2:4]] == ["-", "2.35"]


def test_a_seeds_table_says_each_seed_s_paired_comparison(tmp_path):
    """A summary with `baselines.py --paired` results gets a line per file under its table:
    each seed's wins and losses against the reference, from the file."""
    setup = {"env_id": "TetherNavigate_PostsReach-v3", "env_kwargs": {}, "seeds": [0, 1],
             "timesteps": 1024}  # fmt: skip
    rows = [{"name": "PPO (best)", "success_rate": 0.5, "success_ci": [0.4, 0.6],
             "worst": 0.45, "episodes": 10}]  # fmt: skip
    details = {
        "train_seconds": [60.0, 90.0],
        "paired": {"reference": "lookahead", "reference_success_rate": 0.4, "episodes": 10,
                   "per_seed": [{"seed": 0, "wins": 3, "losses": 1, "mcnemar_p": 0.625},
                                {"seed": 1, "wins": 2, "losses": 2, "mcnemar_p": 1.0}]},
    }  # fmt: skip
    (tmp_path / "summary.json").write_text(_results(rows, setup, details))
    table = tables.seeds_table({"summary.json": BASELINES}, root=tmp_path)
    assert "against lookahead (40.0%) on the same 10 episodes" in table
    assert "seed 0: 3 won, 1 lost (p 0.62); seed 1: 2 won, 2 lost (p 1)" in table


def test_a_ladder_seeds_table_reads_each_summary_s_agent_and_yardsticks(tmp_path):
    """Two tables: one row per summary with a short agent label (the other overrides named in
    the note), the learned agent's best models over seeds, the median train time and the paired
    comparison counted by seed; one row per env id with the planners, the paired reference and
    random in each control mode, from the files."""
    rows = [{"name": "PPO (best)", "success_rate": 0.5, "success_ci": [0.4, 0.6], "worst": 0.45},
            {"name": "PPO (last)", "success_rate": 0.2, "worst": 0.1},
            {"name": "greedy planner", "success_rate": 0.551},
            {"name": "lookahead planner", "success_rate": 0.731},
            {"name": "random", "success_rate": 0.012}]  # fmt: skip
    per_seed = [{"seed": 0, "wins": 1, "losses": 9, "mcnemar_p": 0.02},
                {"seed": 1, "wins": 3, "losses": 4, "mcnemar_p": 1.0},
                {"seed": 2, "wins": 9, "losses": 0, "mcnemar_p": 0.004}]  # fmt: skip
    paired = {"reference": "direct", "reference_success_rate": 0.6, "episodes": 10,
              "per_seed": per_seed}  # fmt: skip
    for control, seconds in (("aim", [60.0, 120.0, 90.0]), ("setup", [60.0, 80.0, 70.0])):
        setup = {
            "algo": "ppo", "env_id": "TetherNavigate_OpenStop-v3", "seeds": [0, 1, 2],
            "env_kwargs": {"control": control}, "timesteps": 1024,
            "hyperparams": {"policy": "AimPolicy", "policy_kwargs": "dict(log_std_init=-2.5)"}
            if control == "aim" else {},
        }  # fmt: skip
        random = {**rows[-1], "success_rate": 0.012 if control == "aim" else 0.003}
        details = {"train_seconds": seconds, **({"paired": paired} if control == "aim" else {})}
        (tmp_path / f"{control}.json").write_text(_results([*rows[:-1], random], setup, details))
    lines = tables.ladder_seeds_table({"*.json": BASELINES}, root=tmp_path).splitlines()
    assert ("| `TetherNavigate_OpenStop-v3` | control:aim | PPO, AimPolicy | 3 x 1,024 | 1.5 | "
            "50.0% [40.0, 60.0] | 45.0% | direct: 1 ahead, 1 behind |") in lines  # fmt: skip
    assert ("| `TetherNavigate_OpenStop-v3` | control:setup | PPO | 3 x 1,024 | 1.2 | "
            "50.0% [40.0, 60.0] | 45.0% | - |") in lines  # fmt: skip
    assert any("other hyperparameters (`policy_kwargs`)" in line for line in lines)
    assert "| env | greedy | lookahead | direct | random, aim | random, setup |" in lines
    assert "| `TetherNavigate_OpenStop-v3` | 55.1% | 73.1% | 60.0% | 1.2% | 0.3% |" in lines
    seeds = tables.seeds_table({"aim.json": BASELINES}, ["PPO (best)"], root=tmp_path)
    assert " | 1.5 | " in seeds.splitlines()[2], "train minutes rounded as in the ladder's table"


def test_a_ladder_seeds_table_refuses_files_whose_yardsticks_differ(tmp_path):
    """Two summaries of one env id whose planners disagree: not one cell for both."""
    setup = {"algo": "ppo", "env_id": "TetherNavigate_OpenStop-v3", "seeds": [0],
             "env_kwargs": {}, "timesteps": 1024}  # fmt: skip
    for name, greedy in (("a", 0.5), ("b", 0.6)):
        rows = [{"name": "PPO (best)", "success_rate": 0.5, "worst": 0.5},
                {"name": "greedy planner", "success_rate": greedy},
                {"name": "lookahead planner", "success_rate": 0.7},
                {"name": "random", "success_rate": 0.0}]  # fmt: skip
        (tmp_path / f"{name}.json").write_text(_results(rows, setup, {"train_seconds": [60.0]}))
    with pytest.raises(ValueError, match=re.escape("greedy 60.0%, another file's 50.0%")):
        tables.ladder_seeds_table({"*.json": BASELINES}, root=tmp_path)


def test_an_imitation_table_reads_each_picker_s_rates(tmp_path):
    """One row per picker: the yardsticks as rates, the students as the mean over network seeds
    with its interval, both over all held-out states and where a detour is needed."""
    seeds = {"mean": 0.5, "ci": [0.4, 0.6], "seeds": [0.45, 0.5, 0.55]}
    setup = {"env_id": "TetherNavigate_PostsReach-v3", "teacher": "aim-search",
             "candidates": 37, "states": 1000, "held_out": 100}  # fmt: skip
    rows = [{"picker": "goal", "in_best": 0.8, "in_best_detour": 0.0},
            {"picker": "random", "in_best": 0.3, "in_best_detour": 0.1},
            {"picker": "student", "features": "observation", "in_best": seeds,
             "in_best_detour": seeds}]  # fmt: skip
    (tmp_path / "imitation.json").write_text(_results(rows, setup, {"detour_share": 0.2}))
    table = tables.imitation_table({"*.json": IMITATION}, root=tmp_path)
    lines = table.splitlines()
    prefix = "| `TetherNavigate_PostsReach-v3` | aim-search, 37 | 100 of 1,000 | 20.0% | "
    assert prefix + "always the goal (the direct shot) | 80.0% | 0.0% |" in lines
    assert prefix + "a random candidate | 30.0% | 10.0% |" in lines
    student = "student: observation, 3 seeds | 50.0% [40.0, 60.0] | 50.0% [40.0, 60.0] |"
    assert prefix + student in lines


# --- tables from docstrings, the command-line reference, the notes' commands ----------------


def test_a_docstring_table_shows_one_row_per_entry():
    """A row with an empty first cell continues the row above (the docstrings' wrapped
    entries): joined, cell by cell; other rows and the text around them as they are."""
    text = (
        "Before.\n\n| Num | Meaning |\n|-----|---------|\n| 0   | the peg whose bearing |\n"
        "|     | is nearest hooks      |\n| 1   | length |\n\nAfter.\n"
    )
    assert docstring_tables.join_table_rows(text) == (
        "Before.\n\n| Num | Meaning |\n|-----|---------|\n"
        "| 0 | the peg whose bearing is nearest hooks |\n| 1 | length |\n\nAfter.\n"
    )


def test_the_cli_reference_renders_any_argparse_parser():
    """Usage in a text block, one table per group with a row per option (or subcommand), help
    expanded as --help expands it, prose with its tables set off and joined."""
    import argparse

    parser = argparse.ArgumentParser(prog="tool", description="Does <things>.")
    parser.add_argument("--count", "-n", type=int, default=3, help="how many (default %(default)s)")
    parser.add_argument("path", help="where")
    commands = parser.add_subparsers(title="commands", dest="command")
    commands.add_parser("run", help="run it")
    parser.epilog = (
        "Its arguments:\n| name | meaning |\n|---|---|\n| `a` | one |\n|  | more |\n\n"
        "commands:\n  run     run it\n  stop    stop it\nThe end."
    )
    text = cli_reference.parser_markdown(parser)
    assert text.startswith("```text\nusage: tool [-h] [--count COUNT]")
    assert "Does &lt;things>." in text
    assert "| `--count`, `-n COUNT` | how many (default 3) |" in text
    assert "| `path` | where |" in text
    assert "| command | meaning |\n|---|---|\n| `run` | run it |" in text
    assert "Its arguments:\n\n| name | meaning |\n|---|---|\n| `a` | one more |" in text
    assert "commands:\n\n- `run`: run it\n- `stop`: stop it\n\nThe end." in text


def test_the_cli_reference_catches_the_parser_of_a_console_script():
    parser = cli_reference.help_parser("python -m tether_gym.training.summary")
    assert parser.prog == "python -m tether_gym.training.summary"


def test_a_long_command_folds_before_its_options_and_unfolds_to_itself():
    command = (
        "python -m benchmarks.experiments.baselines --algo ppo --env ID --hyperparams "
        "'policy_kwargs:dict(net_arch=[256, 256], log_std_init=-2.5)' --timesteps 500000"
    )
    folded = tables.fold_command(command)
    assert folded.splitlines()[0] == "python -m benchmarks.experiments.baselines \\"
    assert all(len(line) <= 90 for line in folded.splitlines())
    assert " ".join(folded.replace("\\\n", " ").split()) == command
    assert tables.fold_command("tether-train --seed 3") == "tether-train --seed 3"
    card = (
        "tether-train --rho 5 100 --seed 3   # = trial seed 3 of: tether-sweep "
        "sweeps/low_stiffness.yml --out runs/sweep-low-stiffness"
    )  # a model card's
    folded = tables.fold_command(card)  # folded before the comment, never inside it
    assert folded.splitlines()[-1] == "  --seed 3   # = trial seed 3 of: tether-sweep " + (
        "sweeps/low_stiffness.yml --out runs/sweep-low-stiffness"
    )
