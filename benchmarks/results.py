"""Every results file with the command that writes it and its cost (the manifest,
`results/manifest.yaml`), and the one command that regenerates all of them or a part.

    python -m benchmarks.results --list                # the parts: files, stale ones, cost
    python -m benchmarks.results ladder --dry-run      # what a part runs, its estimated cost
    python -m benchmarks.results ladder [--overwrite]  # run it (make results PART=ladder)
    python -m benchmarks.results --stale               # regenerate the known-stale files
    python -m benchmarks.results --check               # the manifest and the docs' tables
    python -m benchmarks.results --sync                # the manifest updated from the files

The manifest lists every `results/**/*.json` and every pretrained agent's model card (the
docs' tables read both), by part, in the order they run: each file's command as the file
records it, or for a stale file (`stale`: why, an older env version) the command that writes its
replacement on today's version, and its cost (the recorded `seconds`, or an estimate marked
`estimated`). A run selects parts (or files, by path or glob), prints its plan and estimated
cost, then runs each command once in the manifest's order from the repository's root with this
interpreter's `python` and console scripts first on PATH. It refuses before running anything
where a file it writes exists, unless `--overwrite`: then the old file is moved to
`build/results-previous/` during its command and put back if the command fails. Entries
marked `manual` (a model card: a training run picked by a person, then `tether export`) are
listed, never run.

`--check` and `tests/contracts/test_results_manifest.py` hold the manifest to the files (every
file listed, each command the recorded one unless stale, a file on an older version marked) and
each docs table to both (`docs_problems`): the command shown under a table is its files'
recorded command, not a template, and its files are on today's env versions unless the macro
call says the table compares with an older version (`older_version=True`). A stale file is
exempt, and listed: it is what `--stale` regenerates.
"""

from __future__ import annotations

import argparse
import fnmatch
import json
import os
import re
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from benchmarks.common import ROOT

MANIFEST = Path("results/manifest.yaml")
"""The manifest, relative to the repository's root."""
CARDS = "tether_gym/agents/pretrained"
"""The pretrained agents' model cards (`*.md`), which the docs' tables read too."""
BACKUP = Path("build/results-previous")
"""Where `--overwrite` keeps a file while its command runs."""
TEMPLATE = re.compile(r"\.\.\.|<[^<>\s]+>|\b(?:ID|NAME|RUN_DIR|DIR|PATH|FILE|REV)\b")
"""A placeholder in a command (`--env ID`, `RUN_DIR NAME`, `--command '...'`): a template, not
a command that ran."""
MARKS = ("stale", "older_version", "manual")
HEADER = """\
# Every results file (results/**/*.json) and every pretrained agent's model card
# (tether_gym/agents/pretrained/*.md), by part, in the order `make results` runs them
# (benchmarks/results.py; docs: Results, "Regenerating the results").
#
#   path           the file
#   command        the command that writes it, as the file records it (a list: the commands
#                  of a merged file, run in order); for a stale file, the command that writes
#                  its replacement on today's env version
#   seconds        what it costs: the file's recorded wall time, else an estimate
#   estimated      true where `seconds` is an estimate
#   stale          why the file is not what its command writes today: the list that
#                  `make results STALE=1` regenerates
#   older_version  why it stays on an older env version (a table that compares, and says so)
#   manual         why `make results` does not run it, and what does
#
# tests/contracts/test_results_manifest.py holds it to the files and the docs' tables to both;
# `python -m benchmarks.results --sync` updates it from the files (new files, their recorded
# commands and seconds, stale marks no longer true).
"""


@dataclass(frozen=True)
class Entry:
    """One file of the manifest."""

    part: str
    path: str
    """Relative to the repository's root."""
    commands: tuple[str, ...]
    """The commands that write it, in order (one but for a merged file)."""
    seconds: float | None
    estimated: bool = False
    stale: str | None = None
    older_version: str | None = None
    manual: str | None = None

    @property
    def command(self) -> str:
        """The command the file records (a merged file's last)."""
        return self.commands[-1]

    @property
    def target(self) -> str:
        """The file its command writes: its own path, or for a stale file the path with each
        env id on today's version (`-v2` -> `-v3`)."""
        return current_path(self.path) if self.stale else self.path


@dataclass(frozen=True)
class Recorded:
    """What a file says of itself: its commands, its wall time and the env ids it names."""

    commands: tuple[str, ...]
    seconds: float | None
    ids: dict[str, str]
    """Each env id of its setup, rows and details (a card: its env_id) -> the id of that env's
    newest version."""

    @property
    def command(self) -> str:
        return self.commands[-1]

    @property
    def older(self) -> list[str]:
        """Its env ids on an older version than today's."""
        return sorted(env_id for env_id, newest in self.ids.items() if env_id != newest)


@dataclass
class Job:
    """One command of a run and the manifest entries it writes."""

    part: str
    commands: tuple[str, ...]
    entries: list[Entry] = field(default_factory=list)

    @property
    def command(self) -> str:
        """The command its files record (a merged file's last)."""
        return self.commands[-1]

    @property
    def targets(self) -> list[str]:
        return list(dict.fromkeys(entry.target for entry in self.entries))

    @property
    def seconds(self) -> float:
        """Its cost: per file it writes, the largest of the entries it replaces."""
        by_target: dict[str, float] = {}
        for entry in self.entries:
            by_target[entry.target] = max(by_target.get(entry.target, 0), entry.seconds or 0)
        return sum(by_target.values())

    @property
    def estimated(self) -> bool:
        return any(entry.estimated for entry in self.entries)


# --- the manifest --------------------------------------------------------------------------


def load(path: Path | None = None, root: Path = ROOT) -> list[Entry]:
    """The manifest's entries in order; ValueError naming an entry with an unknown or missing
    field."""
    import yaml

    data = yaml.safe_load((root / (path or MANIFEST)).read_text()) or {}
    entries = []
    for part, items in data.items():
        for item in items or []:
            unknown = set(item) - {"path", "command", "seconds", "estimated", *MARKS}
            if unknown or "path" not in item or "command" not in item:
                raise ValueError(
                    f"{MANIFEST}, part {part}: an entry needs path and command and "
                    f"has no other fields than those of the header, got "
                    f"{sorted(item)}"
                )
            command = item["command"]
            commands = tuple(command) if isinstance(command, list) else (command,)
            entries.append(
                Entry(
                    part,
                    item["path"],
                    commands,
                    item.get("seconds"),
                    bool(item.get("estimated")),
                    *(item.get(mark) for mark in MARKS),
                )
            )
    return entries


def dump(entries: list[Entry]) -> str:
    """The manifest's text (strings JSON-quoted: valid YAML, whatever their quotes)."""

    def text(value: str) -> str:
        return json.dumps(value, ensure_ascii=False)

    lines = [HEADER.rstrip("\n")]
    for part in dict.fromkeys(entry.part for entry in entries):
        lines += ["", f"{part}:"]
        for entry in (entry for entry in entries if entry.part == part):
            lines.append(f"  - path: {entry.path}")
            if len(entry.commands) == 1:
                lines.append(f"    command: {text(entry.command)}")
            else:
                lines += ["    command:", *(f"      - {text(c)}" for c in entry.commands)]
            seconds = "null" if entry.seconds is None else f"{entry.seconds:g}"
            lines.append(f"    seconds: {seconds}")
            if entry.estimated:
                lines.append("    estimated: true")
            for mark in MARKS:
                if getattr(entry, mark):
                    lines.append(f"    {mark}: {text(getattr(entry, mark))}")
    return "\n".join(lines) + "\n"


def result_files(root: Path = ROOT) -> list[str]:
    """Every file the manifest must list: the results files and the model cards."""
    found = [*(root / "results").rglob("*.json"), *(root / CARDS).glob("*.md")]
    return sorted(path.relative_to(root).as_posix() for path in found)


def recorded(path: str, root: Path = ROOT) -> Recorded:
    """What the file `path` records: a results file's `command` (a merged file's
    `details.commands`), `seconds` and env ids; a model card's `command` and `env_id`."""
    from tether_gym.evaluation import results_file

    if path.endswith(".md"):
        import yaml

        front = yaml.safe_load((root / path).read_text().split("---\n", 2)[1])
        return Recorded((front["command"],), None, results_file.env_ids(front["env_id"]))
    data = results_file.read(root / path)
    merged = data["details"].get("commands")
    commands = tuple(merged) if isinstance(merged, list) and merged else (data["command"],)
    return Recorded(commands, data["seconds"], results_file.env_ids(data))


def current_path(path: str) -> str:
    """`path` with each env id in it on its newest version."""
    from tether_gym.evaluation import results_file

    for env_id, newest in results_file.env_ids(path).items():
        path = path.replace(env_id, newest)
    return path


def same(a: tuple[str, ...] | str, b: tuple[str, ...] | str) -> bool:
    """The same command(s), whitespace aside."""
    a, b = ((x,) if isinstance(x, str) else x for x in (a, b))
    return [" ".join(c.split()) for c in a] == [" ".join(c.split()) for c in b]


def estimate(path: str, root: Path = ROOT) -> float | None:
    """A cost for a file that records none, from what it does record: a summary over seeds'
    training (its seeds' train seconds over its `--jobs`, and a minute a seed to play them and
    the yardsticks), a run's own training, an evaluation's episodes at its agents' episodes per
    second, a cold start's processes; None where it records nothing of the kind."""
    data = json.loads((root / path).read_text())
    details, rows, setup = data["details"], data["rows"], data["setup"]
    if isinstance(details.get("train_seconds"), list):
        jobs = re.search(r"--jobs (\d+)", data["command"])
        train = sum(details["train_seconds"]) / (int(jobs[1]) if jobs else 2)
        return round(train + 60 * len(details["train_seconds"]), -1)
    if rows and all("train_seconds" in row for row in rows):
        return round(sum(row["train_seconds"] for row in rows) + 60, -1)
    if rows and all("episodes_per_second" in row for row in rows):
        return round(sum(row["episodes"] / row["episodes_per_second"] for row in rows) + 10)
    if rows and all("trees" in row for row in rows):
        walls = sum(tree["wall"] for row in rows for tree in row["trees"].values())
        return round(walls * setup.get("repeats", 1), -1)
    return None


# --- checks --------------------------------------------------------------------------------


def manifest_problems(entries: list[Entry], root: Path = ROOT) -> list[str]:
    """What is not true of the manifest: a file missing from it or listed twice, an entry
    without its file, and per entry (`entry_problems`)."""
    listed = [entry.path for entry in entries]
    files = set(result_files(root))
    problems = [
        f"{path}: listed twice" for path in sorted({p for p in listed if listed.count(p) > 1})
    ]
    problems += [
        f"{path}: in no entry of {MANIFEST} (`python -m benchmarks.results --sync` adds it)"
        for path in sorted(files - set(listed))
    ]
    problems += [
        f"{path}: listed in {MANIFEST}, but there is no such file (--sync drops it)"
        for path in sorted(set(listed) - files)
    ]
    for entry in entries:
        if entry.path in files:
            problems += entry_problems(entry, recorded(entry.path, root))
    return problems


def entry_problems(entry: Entry, found: Recorded) -> list[str]:
    """What is not true of one entry against its file: its cost (the recorded seconds, else an
    estimate marked so), its command (the recorded one unless stale), its version marks (a file
    on an older version is stale or kept on purpose; a mark that no longer holds goes)."""
    problems, name = [], entry.path
    if found.seconds is not None:
        if entry.estimated or entry.seconds != round(found.seconds):
            problems.append(
                f"{name}: cost {entry.seconds} s, but the file records "
                f"{round(found.seconds)} s (not an estimate)"
            )
    elif entry.seconds is None or entry.seconds <= 0 or not entry.estimated:
        problems.append(
            f"{name}: the file records no seconds: estimate its cost (seconds, estimated: true)"
        )
    if entry.stale and entry.older_version:
        problems.append(f"{name}: stale (to regenerate) or older_version (kept), not both")
    if entry.stale:
        if found.ids and not found.older and same(found.commands, entry.commands):
            problems.append(
                f"{name}: marked stale, but it is on today's version and records its "
                "command: drop the mark (--sync does)"
            )
    else:
        if not same(found.commands, entry.commands):
            problems.append(
                f"{name}: the manifest's command `{entry.command}`, but the file "
                f"records `{found.command}`: copy it (--sync does), or mark the entry "
                "stale with why"
            )
        if found.older and not entry.older_version:
            problems.append(
                f"{name}: on an older version ({', '.join(found.older)}): mark it "
                "stale (to regenerate) or older_version (kept for a comparison)"
            )
    if entry.older_version and found.ids and not found.older:
        problems.append(f"{name}: marked older_version, but it is on today's version")
    if not entry.manual and any(TEMPLATE.search(c) for c in entry.commands):
        problems.append(f"{name}: a template command, not one that runs: {entry.command}")
    return problems


def _docgen():
    """The docs' modules, as `docs/hooks.py` finds them."""
    docs = str(ROOT / "docs")
    if docs not in sys.path:
        sys.path.insert(0, docs)
    from docgen import macros, readme, results

    return macros, readme, results


def doc_pages(root: Path = ROOT) -> list[Path]:
    """The pages whose results tables are checked: the docs' and the README."""
    pages = sorted(p for p in (root / "docs").rglob("*.md") if "figures" not in p.parts)
    return [*pages, root / "README.md"]


def results_calls(page: Path) -> list[tuple[str, dict[str, str], dict[str, Any]]]:
    """A page's results macro calls (its placeholders and the README's generated blocks): each
    macro's name, its sources (`{files glob: the command shown}`) and its keywords."""
    macros, readme, _ = _docgen()
    text = page.read_text()
    calls = [*macros.PLACEHOLDER.findall(text), *(m[1] for m in readme.README_BLOCK.findall(text))]
    found = []
    for call in calls:
        name, args, kwargs = macros.parse_call(call)
        if name in macros.RESULTS_MACROS:
            found.append((name, args[0] if args else kwargs["sources"], kwargs))
    return found


def docs_problems(
    entries: list[Entry], root: Path = ROOT, pages: list[Path] | None = None
) -> tuple[list[str], list[str]]:
    """Each results table of `pages` (default: the docs' and the README) against its files and
    the manifest: every file in the manifest; the command shown for it the one it records (a
    merged file's last), no template; its env ids today's, unless the call is marked
    `older_version=True` (a comparison with an older version, which its table says); a call so
    marked reads a file on an older version. A stale file is exempt. Returns the problems and
    the exempt (the known-stale files the tables show), one line each."""
    _, _, results = _docgen()
    by_path = {entry.path: entry for entry in entries}
    problems, known = [], []
    for page in pages if pages is not None else doc_pages(root):
        name = page.relative_to(root).as_posix() if page.is_relative_to(root) else page.name
        for macro, sources, kwargs in results_calls(page):
            compares, older_read = bool(kwargs.get("older_version")), False
            for pattern, shown in sources.items():
                where = f"{name}, {macro}({pattern})"
                for path in results.files_of(pattern, root):
                    file = path.relative_to(root).as_posix()
                    entry = by_path.get(file)
                    if entry is None:
                        problems.append(f"{where}: {file} is in no entry of {MANIFEST}")
                        continue
                    found = recorded(file, root)
                    older_read |= bool(found.older)
                    if entry.stale:
                        known.append(f"{where}: {file}: {entry.stale}")
                        continue
                    if TEMPLATE.search(shown):
                        problems.append(
                            f"{where}: shows a template, `{shown}`, where {file} "
                            f"records `{found.command}`"
                        )
                    elif not same(shown, found.command):
                        problems.append(
                            f"{where}: shows `{shown}`, but {file} records `{found.command}`"
                        )
                    if found.older and not compares:
                        problems.append(
                            f"{where}: {file} is on an older version "
                            f"({', '.join(found.older)}) in a table not marked as a "
                            "comparison (older_version=True)"
                        )
            if compares and not older_read:
                problems.append(
                    f"{name}, {macro}: marked older_version=True, but none of its "
                    "files is on an older version"
                )
    return problems, known


# --- updating the manifest -----------------------------------------------------------------


def sync(entries: list[Entry], root: Path = ROOT) -> list[Entry]:
    """The manifest updated from the files: an entry whose file is gone dropped; each file's
    recorded seconds, and the recorded commands of a file not stale; a stale mark dropped where
    the file is on today's version and records the entry's command; each new file added to the
    part of the stale entry it replaces (else of its folder's entries, else its folder's name)
    with its recorded command and seconds (else an estimate, else its predecessor's)."""
    files = result_files(root)
    kept = []
    for entry in entries:
        if entry.path not in files:
            continue
        found = recorded(entry.path, root)
        if entry.stale and found.ids and not found.older and same(found.commands, entry.commands):
            entry = replace(entry, stale=None)
        if not entry.stale:
            entry = replace(entry, commands=found.commands)
        if found.seconds is not None:
            entry = replace(entry, seconds=round(found.seconds), estimated=False)
        kept.append(entry)
    listed = {entry.path for entry in kept}
    replaced = {entry.target: entry for entry in kept if entry.stale}
    for path in (path for path in files if path not in listed):
        found, before = recorded(path, root), replaced.get(path)
        folder = path.rsplit("/", 1)[0]
        parts = {entry.part for entry in kept if entry.path.rsplit("/", 1)[0] == folder}
        part = before.part if before else parts.pop() if len(parts) == 1 else folder.split("/")[-1]
        seconds, estimated = found.seconds, False
        if seconds is None:
            seconds = None if path.endswith(".md") else estimate(path, root)
            seconds, estimated = seconds or (before.seconds if before else None), True
        new = Entry(
            part, path, found.commands, None if seconds is None else round(seconds), estimated
        )
        at = max((i for i, e in enumerate(kept) if e.part == part), default=len(kept) - 1)
        kept.insert(at + 1, new)
    return kept


# --- running -------------------------------------------------------------------------------


def select(entries: list[Entry], selectors: list[str], stale_only: bool = False) -> list[Entry]:
    """The entries of the parts named, or of the files a path or glob names (all without a
    selector), in the manifest's order; only the stale ones with `stale_only`. ValueError for a
    selector that names nothing."""
    chosen = list(entries)
    if selectors:
        picked: set[int] = set()
        for selector in selectors:
            hits = [
                i
                for i, e in enumerate(entries)
                if e.part == selector or fnmatch.fnmatch(e.path, selector)
            ]
            if not hits:
                parts = ", ".join(dict.fromkeys(e.part for e in entries))
                raise ValueError(
                    f"{selector!r} is no part and no file of {MANIFEST}; the parts: {parts}"
                )
            picked.update(hits)
        chosen = [entries[i] for i in sorted(picked)]
    return [entry for entry in chosen if entry.stale or not stale_only]


def jobs_of(entries: list[Entry]) -> list[Job]:
    """The commands that write `entries`, each once, in the order of its first entry."""
    jobs: dict[tuple[str, ...], Job] = {}
    for entry in entries:
        jobs.setdefault(entry.commands, Job(entry.part, entry.commands)).entries.append(entry)
    return list(jobs.values())


def duration(seconds: float) -> str:
    if seconds < 120:
        return f"{seconds:.0f} s"
    return f"{seconds / 60:.0f} min" if seconds < 7200 else f"{seconds / 3600:.1f} h"


def plan(jobs: list[Job], root: Path = ROOT) -> list[str]:
    """What a run does, one command at a time: its part and cost, and each file it writes
    (from the stale file it replaces; marked where it exists); then the total."""
    lines, total, estimated = [], 0.0, False
    for job in jobs:
        manual = next((entry.manual for entry in job.entries if entry.manual), None)
        cost = ("~" if job.estimated else "") + duration(job.seconds)
        lines.append(f"[{job.part}] {cost}{'  (manual: not run)' if manual else ''}")
        lines += [f"  $ {command}" for command in job.commands]
        for entry in job.entries:
            line = f"    {entry.path}"
            if entry.target != entry.path:
                line += f" -> {entry.target}"
            if entry.stale:
                line += "  (stale)"
            if not manual and (root / entry.target).exists():
                line += "  [exists]"
            lines.append(line)
        if manual:
            lines.append(f"    manual: {manual}")
        else:
            total += job.seconds
            estimated |= job.estimated
    runs = [job for job in jobs if not any(entry.manual for entry in job.entries)]
    lines.append(
        f"{len(runs)} command{'s' * (len(runs) != 1)} to run, about "
        f"{duration(total)}{' (estimated in part)' * estimated}"
    )
    return lines


def run(jobs: list[Job], overwrite: bool = False, root: Path = ROOT) -> int:
    """Run each job's commands in order from `root` (this interpreter's folder first on PATH).
    Refuses (2) before running anything where a file a job writes exists, unless `overwrite`:
    then the file waits in `BACKUP` while its command runs and comes back if it fails. After
    each job, says what it wrote against the manifest (the command recorded, the version).
    Stops at the first failing command, with its status."""
    runnable = [job for job in jobs if not any(entry.manual for entry in job.entries)]
    existing = [t for job in runnable for t in job.targets if (root / t).exists()]
    if existing and not overwrite:
        print(
            f"refused: {len(existing)} file(s) it writes exist; pass --overwrite "
            "(make results OVERWRITE=1) to replace them:",
            *existing,
            sep="\n  ",
        )
        return 2
    env = dict(
        os.environ,
        PATH=os.pathsep.join([str(Path(sys.executable).parent), os.environ.get("PATH", "")]),
    )
    walls = []
    for job in runnable:
        kept = {t: root / BACKUP / t for t in job.targets if (root / t).exists()}
        for target, backup in kept.items():
            backup.parent.mkdir(parents=True, exist_ok=True)
            shutil.move(root / target, backup)
        print(f"\n[{job.part}] ~{duration(job.seconds)}", flush=True)
        started, status = time.perf_counter(), 0
        for command in job.commands:
            print(f"$ {command}", flush=True)
            status = subprocess.run(
                command, shell=True, cwd=root, env=env, executable="/bin/bash"
            ).returncode
            if status:
                break
        wall = time.perf_counter() - started
        for target, backup in kept.items():
            if status and not (root / target).exists():
                shutil.move(backup, root / target)
            elif backup.exists():
                backup.unlink()
        if status:
            print(
                f"[{job.part}] failed ({status}) after {duration(wall)}: {job.command}; "
                "the files it would replace are back"
            )
            return status
        walls.append((job, wall))
        for line in wrote(job, root):
            print(line)
    print("\nwall time per command:")
    for job, wall in walls:
        print(
            f"  {duration(wall):>8} (manifest: {duration(job.seconds)}) [{job.part}] {job.command}"
        )
    if walls:
        print(
            f"then: python -m benchmarks.results --sync (the new files into {MANIFEST}), "
            "and the docs' tables to read them"
        )
    return 0


def wrote(job: Job, root: Path = ROOT) -> list[str]:
    """What a finished job wrote, file by file: missing, another command recorded, an older
    version still, or as the manifest says."""
    lines = []
    for target in job.targets:
        if not (root / target).exists():
            lines.append(f"  {target}: not written")
            continue
        found = recorded(target, root)
        if not same(found.commands[-1], job.command):
            lines.append(f"  {target}: records `{found.command}`, not the manifest's command")
        elif found.older:
            lines.append(f"  {target}: still on an older version ({', '.join(found.older)})")
        else:
            took = "" if found.seconds is None else f", {found.seconds} s"
            lines.append(f"  {target}: written{took}")
    return lines


# --- the command line ----------------------------------------------------------------------


def summary(entries: list[Entry]) -> list[str]:
    """Per part: its files, the stale ones, the manual ones (never run), and what a run of the
    part costs, all of it and its stale files only; then the totals."""
    lines = [
        "| part | files | stale | manual | cost | cost of the stale |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    parts = list(dict.fromkeys(entry.part for entry in entries))
    for part in [*parts, None]:
        chosen = [entry for entry in entries if part is None or entry.part == part]
        run = [entry for entry in chosen if not entry.manual]
        cost = sum(job.seconds for job in jobs_of(run))
        stale = sum(job.seconds for job in jobs_of([entry for entry in run if entry.stale]))
        lines.append(
            f"| {part or 'all'} | {len(chosen)} | {sum(bool(e.stale) for e in chosen)} | "
            f"{len(chosen) - len(run)} | ~{duration(cost)} | ~{duration(stale)} |"
        )
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.results", description=__doc__.split("\n\n")[0]
    )
    parser.add_argument(
        "select",
        nargs="*",
        metavar="PART|FILE",
        help="parts of the manifest, or files (paths or globs); default: all",
    )
    parser.add_argument("--stale", action="store_true", help="only the known-stale files")
    parser.add_argument("--dry-run", action="store_true", help="print the plan, run nothing")
    parser.add_argument("--overwrite", action="store_true", help="replace files that exist")
    parser.add_argument("--list", action="store_true", help="the parts: files, stale, cost")
    parser.add_argument(
        "--check", action="store_true", help="the manifest and the docs' tables against the files"
    )
    parser.add_argument("--sync", action="store_true", help="update the manifest from the files")
    args = parser.parse_args(argv)
    entries = load()
    if args.sync:
        (ROOT / MANIFEST).write_text(dump(sync(entries)))
        print(f"wrote {MANIFEST}")
        return 0
    if args.list:
        print("\n".join(summary(entries)))
        return 0
    if args.check:
        problems = manifest_problems(entries)
        shown, known = docs_problems(entries)
        print(f"known stale, shown in the docs ({len(known)}):", *known, sep="\n  ")
        print(f"problems ({len(problems) + len(shown)}):", *problems, *shown, sep="\n  ")
        return 1 if problems or shown else 0
    try:
        jobs = jobs_of(select(entries, args.select, args.stale))
    except ValueError as error:
        parser.error(str(error))
    print("\n".join(plan(jobs)))
    return 0 if args.dry_run else run(jobs, args.overwrite)


if __name__ == "__main__":
    sys.exit(main())
