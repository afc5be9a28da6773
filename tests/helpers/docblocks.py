"""The code blocks of Markdown files, and how the docs' tests run them.

A fenced block is run by its language: `python` blocks are executed, `bash` blocks run
command by command (in-process, through the console scripts' `main`), each with a small budget
where it trains or evaluates (`budget`). A block whose commands cannot run in a test (installs,
`make`, a Ray cluster) says so on the line before it, in a comment the page does not show:

    <!-- not run: installs packages -->

`text` blocks are output, not code. Any other language fails the docs' tests until it is
given a way to run or such a comment.
"""

from __future__ import annotations

import re
import shlex
from dataclasses import dataclass
from pathlib import Path

FENCE = re.compile(r"^```(\w*)[^\n]*\n(.*?)^```", re.DOTALL | re.MULTILINE)
NOT_RUN = re.compile(r"<!-- not run: (.+?) -->\s*$")
RUNS = ("python", "bash")
OUTPUT = ("text",)


@dataclass
class Block:
    path: Path
    line: int
    language: str
    code: str
    not_run: str | None
    """The reason the block is not run, from its `<!-- not run: ... -->` comment."""

    @property
    def id(self) -> str:
        return f"{self.path.name}:{self.line}"


def blocks(path: Path) -> list[Block]:
    """The fenced blocks of a Markdown file (`text` output blocks left out)."""
    text = path.read_text()
    found = []
    for match in FENCE.finditer(text):
        language = match.group(1)
        if language in OUTPUT:
            continue
        before = text[: match.start()].rstrip("\n").rsplit("\n", 1)[-1]
        reason = NOT_RUN.search(before)
        line = text.count("\n", 0, match.start()) + 1
        found.append(Block(path, line, language, match.group(2), reason and reason.group(1)))
    return found


def commands(code: str) -> list[list[str]]:
    """A bash block's commands as argument lists: continuations joined, comments dropped."""
    joined = code.replace("\\\n", " ")
    return [words for line in joined.splitlines() if (words := shlex.split(line, comments=True))]


def _set(argv: list[str], flag: str, value: str) -> list[str]:
    """`argv` with `flag value` (replacing the flag's value if it is there)."""
    if flag in argv:
        i = argv.index(flag)
        return [*argv[: i + 1], value, *argv[i + 2 :]]
    return [*argv, flag, value]


def budget(words: list[str]) -> tuple[str, list[str]]:
    """The program (a console script, or `-m module`) and its arguments, cut to a test's
    budget: few episodes, a few hundred timesteps, no progress bars. ValueError for a program
    the docs' tests do not run."""
    if words[:2] == ["python", "-m"]:
        program, argv = f"-m {words[2]}", words[3:]
    else:
        program, argv = words[0], words[1:]
    if program == "tether-evaluate":
        argv = _set(argv, "--episodes", "10")
        return program, [*argv, "--no-progress-bar"]
    if program == "tether-train":
        argv = _set(argv, "--timesteps", "1024" if "--resume" in argv else "512")
        argv = _set(argv, "--eval-episodes", "10")
        argv = _set(argv, "--eval-freq", "256")
        if "--resume" not in argv:
            argv = _set(argv, "--n-envs", "4")
        return program, [*argv, "--no-progress-bar"]
    if program == "-m tether_gym.agents.record":
        return program, _set(argv, "--episodes", "1")
    if program in ("tether-figures", "-m tether_gym.training.summary"):
        return program, argv
    raise ValueError(
        f"the docs' tests do not run {' '.join(words[:3])!r}: give it a budget in "
        "tests/docblocks.py, or mark its block <!-- not run: reason -->"
    )
