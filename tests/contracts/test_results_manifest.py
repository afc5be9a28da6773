"""The results manifest (`results/manifest.yaml`, `benchmarks/results.py`): it lists every
results file with the command that writes it, and each docs table shows the command its files
record, on today's env versions. A stale file (an older version's, to regenerate) is marked
in the manifest; the tables that show one are exempt, and listed by
`python -m benchmarks.results --check`."""

from __future__ import annotations

import json
import sys
from dataclasses import replace
from pathlib import Path

import pytest

from benchmarks import results
from benchmarks.experiments import ladder
from tests.helpers import ROOT
from tether_gym.evaluation import results_file

OLD, NEW = "TetherNavigate_OpenReach-v2", "TetherNavigate_OpenReach-v3"
"""An older version's id and today's (the test reads the registry's newest)."""
EVALUATE = "tether-evaluate --env {id} --agents random --json results/x/{id}.json"


def test_the_manifest_lists_every_results_file_with_the_command_it_records():
    problems = results.manifest_problems(results.load())
    assert not problems, "results/manifest.yaml:\n" + "\n".join(problems)


def test_every_docs_table_shows_the_command_its_files_record_on_today_s_version():
    """Every results table of the docs and the README: the command shown under it is the one
    its files record, no template, on today's env versions (or marked as a comparison). The
    known-stale files of the manifest are exempt (`python -m benchmarks.results --check` lists
    them): `make results STALE=1` regenerates them."""
    problems, known = results.docs_problems(results.load())
    assert not problems, "\n".join(problems)
    assert all(": " in line for line in known)


def test_the_current_version_is_what_the_registry_says():
    assert results_file.env_ids(OLD) == {OLD: NEW}
    assert results_file.env_ids(f"results/ladder/{NEW}_setup.json") == {NEW: NEW}
    assert results_file.env_ids("ppo_TetherBounce-v0.json x-CartPole-v1") == {
        "TetherBounce-v0": "TetherBounce-v0",
        "CartPole-v1": "CartPole-v1",
    }
    assert results.current_path(f"results/baselines/sac_{OLD}_control-aim.json") == (
        f"results/baselines/sac_{NEW}_control-aim.json"
    )


# --- the checks on a small repository ---------------------------------------------------------


def write(root: Path, env_id: str, command: str | None = None, seconds: float | None = 3.0):
    """A results file of `env_id` under `root`, recording `command` (default: EVALUATE's)."""
    command = command or EVALUATE.format(id=env_id)
    row = {"name": "random", "episodes": 10, "success_rate": 0.5, "success_ci": [0.2, 0.8]}
    data = results_file.record(
        command, [row], {"env_id": env_id, "env_kwargs": {}}, seconds=seconds, root=root
    )
    results_file.write(root / "results" / "x" / f"{env_id}.json", data)
    return f"results/x/{env_id}.json"


def entry(path: str, **fields) -> results.Entry:
    env_id = Path(path).stem
    fields.setdefault("commands", (EVALUATE.format(id=env_id),))
    fields.setdefault("seconds", 3)
    return results.Entry("x", path, **fields)


def page(root: Path, sources: dict[str, str], older: bool = False) -> Path:
    mark = ", older_version=True" if older else ""
    path = root / "docs" / "page.md"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(f"# A page\n\n{{{{ success_table({json.dumps(sources)}{mark}) }}}}\n")
    return path


def check(root: Path, entries: list[results.Entry], sources: dict[str, str], older=False):
    """The manifest's problems and the page's (problems, known stale)."""
    shown = results.docs_problems(entries, root, [page(root, sources, older)])
    return results.manifest_problems(entries, root), shown


def test_a_page_showing_the_files_command_on_today_s_version_passes(tmp_path):
    path = write(tmp_path, NEW)
    assert check(tmp_path, [entry(path)], {path: EVALUATE.format(id=NEW)}) == ([], ([], []))


def test_a_page_showing_another_command_or_a_template_fails(tmp_path):
    path = write(tmp_path, NEW)
    _, (problems, _) = check(tmp_path, [entry(path)], {path: "tether-evaluate --env " + NEW})
    assert len(problems) == 1 and "shows `tether-evaluate --env" in problems[0]
    assert f"{path} records `{EVALUATE.format(id=NEW)}`" in problems[0]
    for template in ("tether-evaluate --env ID", "tether export RUN_DIR NAME --command '...'"):
        _, (problems, _) = check(tmp_path, [entry(path)], {path: template})
        assert len(problems) == 1 and "shows a template" in problems[0]


def test_a_file_on_an_older_version_fails_unless_marked(tmp_path):
    path = write(tmp_path, OLD)
    manifest, (problems, known) = check(tmp_path, [entry(path)], {path: EVALUATE.format(id=OLD)})
    assert len(manifest) == 1 and f"on an older version ({OLD})" in manifest[0]
    assert len(problems) == 1 and "not marked as a comparison" in problems[0] and not known
    # known-stale: exempt, and listed
    stale = entry(path, commands=(EVALUATE.format(id=NEW),), stale="on -v2, to regenerate")
    assert check(tmp_path, [stale], {path: "anything"}) == (
        [],
        ([], [f"docs/page.md, success_table({path}): {path}: on -v2, to regenerate"]),
    )
    assert stale.target == f"results/x/{NEW}.json"
    # kept for a comparison that the table says it is
    kept = entry(path, older_version="the v2 side of a comparison")
    sources = {path: EVALUATE.format(id=OLD)}
    assert check(tmp_path, [kept], sources, older=True) == ([], ([], []))
    table = page(tmp_path, sources, older=True).read_text()
    macros, _, _ = results._docgen()
    call = macros.PLACEHOLDER.findall(table)[0]
    assert "measured on that version, not on today's `-v3`" in macros.expand(call, tmp_path)


def test_a_comparison_mark_without_an_older_file_fails(tmp_path):
    path = write(tmp_path, NEW)
    _, (problems, _) = check(tmp_path, [entry(path)], {path: EVALUATE.format(id=NEW)}, older=True)
    assert len(problems) == 1 and "none of its files is on an older version" in problems[0]


def test_the_manifest_fails_where_it_and_the_files_disagree(tmp_path):
    path, other = write(tmp_path, NEW), write(tmp_path, "TetherBounce-v0", "python x.py")
    gone = entry("results/x/gone.json")
    problems = results.manifest_problems([entry(path, commands=("python y.py",)), gone], tmp_path)
    assert any(f"{other}: in no entry" in p for p in problems)
    assert any("results/x/gone.json: listed in" in p and "no such file" in p for p in problems)
    assert any(f"{path}: the manifest's command `python y.py`" in p for p in problems)
    fresh = entry(path, stale="on -v2")  # today's version and its command: no longer stale
    problems = results.manifest_problems([fresh, entry(other, commands=("python x.py",))], tmp_path)
    assert len(problems) == 1 and f"{path}: marked stale, but" in problems[0]
    for wrong in (entry(path, seconds=9), entry(path, estimated=True)):  # the file records 3 s
        problems = results.manifest_problems(
            [wrong, entry(other, commands=("python x.py",))], tmp_path
        )
        assert len(problems) == 1 and "but the file records 3 s" in problems[0]
    unrecorded = write(tmp_path, "TetherBounce-v0", "python x.py", seconds=None)
    problems = results.manifest_problems(
        [entry(path), entry(unrecorded, commands=("python x.py",))], tmp_path
    )
    assert problems == [
        f"{unrecorded}: the file records no seconds: estimate its cost (seconds, estimated: true)"
    ]


def test_sync_records_the_new_files_in_the_part_of_the_stale_ones_they_replace(tmp_path):
    old = write(tmp_path, OLD)
    stale = results.Entry("ladder", old, (EVALUATE.format(id=NEW),), 3, stale="on -v2")
    new = write(tmp_path, NEW, seconds=4.4)
    entries = results.sync([stale], tmp_path)
    assert entries == [stale, results.Entry("ladder", new, (EVALUATE.format(id=NEW),), 4)]
    (tmp_path / old).unlink()  # the old file goes: so does its entry
    assert results.sync(entries, tmp_path) == entries[1:]
    entries[1:] = [replace(entries[1], commands=("a", "b"), older_version="kept")]
    (tmp_path / "m.yaml").write_text(results.dump(entries))
    assert results.load(Path("m.yaml"), tmp_path) == entries  # the text round-trips


# --- running ---------------------------------------------------------------------------------

WRITER = """\
import sys
from pathlib import Path
from tether_gym.evaluation import results_file
if sys.argv[2] == "fail":
    sys.exit(3)
data = results_file.record("python write.py " + " ".join(sys.argv[1:]), [], seconds=1.0)
results_file.write(Path(sys.argv[1]), data)
"""


def test_a_run_refuses_to_overwrite_unless_asked_and_puts_back_a_failed_command_s_file(
    tmp_path, capsys, monkeypatch
):
    monkeypatch.setenv("PYTHONPATH", str(ROOT))
    (tmp_path / "write.py").write_text(WRITER)
    out = "results/w/out.json"
    (tmp_path / "results" / "w").mkdir(parents=True)
    (tmp_path / out).write_text("old")
    good = results.Entry("w", out, (f"python write.py {out} ok",), 1)
    bad = results.Entry("w", out, (f"python write.py {out} fail",), 1)
    [job] = results.jobs_of(results.select([good, bad], ["results/w/*"])[:1])
    assert "[exists]" in "\n".join(results.plan([job], tmp_path))
    assert results.run([job], root=tmp_path) == 2 and (tmp_path / out).read_text() == "old"
    assert "refused: 1 file(s) it writes exist" in capsys.readouterr().out
    assert results.run(results.jobs_of([bad]), overwrite=True, root=tmp_path) == 3
    assert (tmp_path / out).read_text() == "old"  # the failed command's file is back
    assert results.run([job], overwrite=True, root=tmp_path) == 0
    assert results_file.read(tmp_path / out)["command"] == good.command
    assert f"{out}: written, 1.0 s" in capsys.readouterr().out
    assert not list((tmp_path / results.BACKUP).rglob("*.json"))


def test_a_selector_that_names_nothing_says_the_parts():
    with pytest.raises(ValueError, match="the parts: ladder"):
        results.select(results.load(), ["nothing"])


def test_the_ladder_records_its_own_command_and_each_evaluation_s_seconds(tmp_path, monkeypatch):
    monkeypatch.setattr(sys, "argv", ["ladder.py", "--episodes", "2"])
    path = tmp_path / "ladder.json"
    ladder.run(NEW, "setup", ["random"], path, 2, overwrite=False)
    data = results_file.read(path)
    assert data["command"] == "python -m benchmarks.experiments.ladder --episodes 2"
    assert data["seconds"] >= 0 and data["setup"]["env_id"] == NEW  # tether-evaluate's wall time
