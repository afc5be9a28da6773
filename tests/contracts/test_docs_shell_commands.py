"""Every command the docs' generated notes show (under each results table on a page, in the
README's italic lines) pastes into a shell: `shlex.split` reads it, no parenthesis stands outside
quotes, and `bash -n` parses it. A results file recorded before commands kept their quotes
(`policy_kwargs:dict(...)` joined by spaces) is shown quoted (`tables.shell_command`)."""

from __future__ import annotations

import re
import shlex
import shutil
import subprocess
import sys

import pytest

from tests.helpers import ROOT

DOCS = ROOT / "docs"
if str(DOCS) not in sys.path:  # the docs' modules, as docs/hooks.py finds them
    sys.path.insert(0, str(DOCS))

from docgen import macros, readme, tables  # noqa: E402

PAGES = sorted(p for p in DOCS.rglob("*.md") if "figures" not in p.parts)
NOTE_BLOCK = re.compile(r"^    ```bash\n(.*?)^    ```$", re.DOTALL | re.MULTILINE)
"""A command in a page's note (`??? info`): a bash block indented under it."""
README_COMMAND = re.compile(r"written by `([^`]+)`")
"""A command in the README's italic line."""


def shown_commands() -> list[tuple[str, str]]:
    """(where, command) for every command the results tables' notes show: each results
    placeholder of the docs' pages rendered as the site renders it, and each generated block of
    the README as `python docs/hooks.py --readme` writes it; a folded command unfolded."""
    found = []
    for page in PAGES:
        for call in macros.PLACEHOLDER.findall(page.read_text()):
            if macros.parse_call(call)[0] not in macros.RESULTS_MACROS:
                continue
            for block in NOTE_BLOCK.findall(macros.expand(call)):
                unfolded = " ".join(line.strip() for line in block.splitlines())
                found.append((f"{page.name}: {call[:50]}", unfolded.replace(" \\ ", " ")))
    for match in readme.README_BLOCK.finditer((ROOT / "README.md").read_text()):
        for command in README_COMMAND.findall(macros.expand(match[2], style="readme")):
            found.append((f"README.md: {match[2][:50]}", command))
    return found


COMMANDS = shown_commands()


def unquoted_parentheses(command: str) -> list[str]:
    """The parentheses of `command` outside quotes and before a comment (shell syntax, not
    an argument's text): `shlex` with `punctuation_chars` splits them off as tokens of their
    own, of punctuation only, where quotes do not hold them in a word."""
    lexer = shlex.shlex(command, posix=True, punctuation_chars=True)
    lexer.commenters = "#"
    punctuation = set(lexer.punctuation_chars)
    return [token for token in lexer if set(token) <= punctuation and set(token) & set("()")]


def test_the_docs_show_commands_under_their_tables():
    assert len(COMMANDS) > 20
    assert any(where.startswith("README.md") for where, _ in COMMANDS)


@pytest.mark.parametrize("where, command", COMMANDS, ids=[w for w, _ in COMMANDS])
def test_a_shown_command_pastes_into_a_shell(where, command):
    assert shlex.split(command, comments=True), where
    assert not unquoted_parentheses(command), f"{where}: unquoted {command}"
    bash = shutil.which("bash")
    if bash is None:
        pytest.skip("no bash to parse the command")
    parsed = subprocess.run([bash, "-n", "-c", command], capture_output=True, text=True)
    assert parsed.returncode == 0, f"{where}: {parsed.stderr}"


RECORDED = (
    "python -m benchmarks.experiments.baselines --algo ppo --env TetherNavigate_PostsReach-v1 "
    "--hyperparams policy:AimPolicy policy_kwargs:dict(features_extractor_class=NavigateExtractor,"
    " net_arch=dict(pi=[256, 256], vf=[256, 256]), log_std_init=-2.5) --timesteps 500000"
)
"""A command as a results file of v1 records it: its arguments joined by spaces, unquoted."""


def test_a_command_recorded_without_quotes_is_shown_quoted_as_it_ran():
    shown = tables.shell_command(RECORDED)
    words = shlex.split(shown)
    assert words[words.index("policy:AimPolicy") + 1] == (
        "policy_kwargs:dict(features_extractor_class=NavigateExtractor, net_arch=dict(pi=[256, "
        "256], vf=[256, 256]), log_std_init=-2.5)"
    )
    assert words[-2:] == ["--timesteps", "500000"] and not unquoted_parentheses(shown)
    assert unquoted_parentheses(RECORDED)  # what the page showed as the file records it


@pytest.mark.parametrize(
    "command",
    [
        "tether-train --rho 5 100 --seed 3   # = trial seed 3 of: tether-sweep (a sweep)",
        "python -m x --hyperparams 'policy_kwargs:dict(net_arch=[64, 64])' --seed 1",
        'tether-train --hyperparams "policy_kwargs:dict(a=1, b=2)" --env-kwargs "rho:[5, 100]"',
        "python -m x 'pretrain:{planner: aim-search}' --json results/x.json",
    ],
)
def test_a_command_a_shell_reads_is_shown_as_it_is(command):
    assert tables.shell_command(command) == command


def test_a_note_says_where_it_quoted_a_recorded_command(tmp_path):
    """The note under a table shows the command quoted and says that the file records it
    without the quotes; a command already quoted gets no such remark."""
    (tmp_path / "r").mkdir()
    (tmp_path / "r" / "a.json").write_text("{}")
    note = tables.sources_line({"r/a.json": RECORDED}, root=tmp_path)
    assert "'policy_kwargs:dict(" in note and "the file records it without the quotes" in note
    note = tables.sources_line({"r/a.json": tables.shell_command(RECORDED)}, root=tmp_path)
    assert "without the quotes" not in note
