"""`tether export`: a run's policy and its card go to a folder and a name the user chooses,
never into the installed package unless a maintainer asks (`--into-package`); it says what it
plays while it measures the card."""

from __future__ import annotations

import hashlib
from importlib.resources import files
from pathlib import Path

import pytest

from tests.helpers.training import jax_run_folder
from tether_gym.evaluation import export as exporter

PACKAGE = Path(str(files("tether_gym.agents.pretrained")))


def package_files() -> dict[str, str]:
    """The shipped agents' files and a hash of each."""
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in PACKAGE.iterdir()
            if p.is_file()}  # fmt: skip


def test_a_jax_seed_exports_under_a_new_name_into_the_chosen_folder(tmp_path, capsys):
    """A name of the user's, into `--out`: the policy, its network file and its card, a line per
    agent the card plays, and how to play it; the package's files are untouched."""
    pytest.importorskip("flax")
    run, out = tmp_path / "run", tmp_path / "mine"
    jax_run_folder(run, [0, 1])
    out.mkdir()
    shipped = package_files()
    status = exporter.main([str(run), "my-bounce", "--seed", "1", "--out", str(out),
                            "--episodes", "20", "--command", "tether-train --backend jax",
                            "--no-progress-bar"])  # fmt: skip
    assert status == 0
    assert sorted(p.name for p in out.iterdir()) == ["my-bounce.json", "my-bounce.md",
                                                     "my-bounce.msgpack"]  # fmt: skip
    printed = capsys.readouterr().out
    assert "seed 1, its best policy (2,048 timesteps) -> " in printed
    for label in ("policy", "impulse oracle", "shooting oracle"):
        assert f"tether export:   {label}: " in printed
    assert f"play it: tether-evaluate --agents {out / 'my-bounce.msgpack'}" in printed
    assert "name: my-bounce" in (out / "my-bounce.md").read_text()
    assert package_files() == shipped


def test_existing_files_are_replaced_only_with_overwrite(tmp_path):
    """An agent's files in the folder (any format: a stale `.pt` beside a new `.msgpack` would
    be shipped for nothing) are refused before any work, and replaced with `overwrite`."""
    pytest.importorskip("flax")
    run = tmp_path / "run"
    jax_run_folder(run, [0])
    stale = tmp_path / "mine.pt"
    stale.write_text("an older export")
    with pytest.raises(ValueError, match=r"mine\.pt exists; pass --overwrite to replace it"):
        exporter.export(run, "mine", "x", folder=tmp_path, episodes=5)
    policy, card = exporter.export(run, "mine", "x", folder=tmp_path, episodes=5, overwrite=True)
    assert not stale.exists() and policy.name == "mine.msgpack" and card.is_file()


def test_only_the_maintainers_flag_writes_into_the_package(tmp_path, capsys):
    """Without `--into-package` nothing points into the package; with it, NAME is a shipped
    agent's and the files are the catalog's; a folder with it, a new name with it, a name with
    a folder and a file as the folder are refused, each naming what is wrong; a missing folder
    is made when the files are cleared for writing."""
    files_of = exporter.export_files("pretrained", None, into_package=True)
    assert {p.parent for p in files_of.values()} == {PACKAGE}
    assert files_of[".msgpack"].name == "default.msgpack"
    assert exporter.export_files("pretrained", tmp_path)[".md"] == tmp_path / "default.md"
    assert exporter.export_files("mine", tmp_path)[".pt"] == tmp_path / "mine.pt"
    (tmp_path / "file.txt").write_text("a user's file")
    refused = [
        (("mine", None, True), "--into-package replaces a shipped agent, one of"),
        (("pretrained", tmp_path, True), "--into-package writes into the package; drop --out"),
        (("mine", None), r"give the folder to export into \(--out DIR\)"),
        (("../mine", tmp_path), "name must be a file name"),
        (("mine", tmp_path / "file.txt"), "is a file, not a folder"),
    ]
    for arguments, message in refused:
        with pytest.raises(ValueError, match=message):
            exporter.export_files(*arguments)
    with pytest.raises(SystemExit):
        exporter.main([str(tmp_path), "pretrained", "--into-package", "--out", str(tmp_path),
                       "--command", "x"])  # fmt: skip
    assert "--into-package writes into the package; drop --out" in capsys.readouterr().err
    files = exporter.export_files("mine", tmp_path / "new" / "folder")
    exporter.clear_files(files, overwrite=False)
    assert files[".md"].parent.is_dir()


def test_the_help_describes_both_kinds_of_run(capsys):
    with pytest.raises(SystemExit):
        exporter.main(["--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert "an SB3 run's (its best/model.zip) or a --backend jax run's" in out
    assert "--into-package" in out and "--out DIR" in out
