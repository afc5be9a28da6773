"""numba's cached kernels are dropped when the sources they were built from change."""

from pathlib import Path

import tether_gym
from tether_gym import kernel_cache


def make_package(root: Path) -> list[Path]:
    """A package with a kernel layer and a training layer, and numba cache files beside the
    kernel's module; returns the cache files."""
    for name, text in {"physics/step.py": "X = 1\n", "training/train.py": "Y = 1\n"}.items():
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text(text)
    return write_caches(root)


def write_caches(root: Path) -> list[Path]:
    folder = root / "physics" / "__pycache__"
    folder.mkdir(exist_ok=True)
    caches = [folder / "step.kernel-12.py311.nbi", folder / "step.kernel-12.py311.1.nbc"]
    for path in caches:
        path.write_bytes(b"compiled")
    return caches


def test_caches_built_before_any_digest_are_dropped(tmp_path):
    caches = make_package(tmp_path)
    assert kernel_cache.refresh(tmp_path)
    assert not any(path.exists() for path in caches)
    assert (tmp_path / kernel_cache.STAMP).read_text() == kernel_cache.sources_digest(tmp_path)


def test_caches_of_unchanged_sources_are_kept(tmp_path):
    make_package(tmp_path)
    kernel_cache.refresh(tmp_path)
    caches = write_caches(tmp_path)
    (tmp_path / "training" / "train.py").write_text("Y = 2\n")  # above the kernels: no effect
    assert not kernel_cache.refresh(tmp_path)
    assert all(path.exists() for path in caches)


def test_an_edit_outside_the_kernels_sources_keeps_the_key(tmp_path):
    """Evaluation, training, the figures and the CLI are no kernel's source; a module a
    kernel's module imports is, wherever it lives."""
    make_package(tmp_path)
    (tmp_path / "physics" / "step.py").write_text(
        "from tether_gym.shared import constants\n\ndef f():\n    from tether_gym import late\n"
    )
    extra = ("shared/__init__.py", "shared/constants.py", "late.py", "evaluation/cli.py",
             "figures.py", "cli.py")  # fmt: skip
    for name in extra:
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text("X = 1\n")
    key = kernel_cache.sources_digest(tmp_path)
    for name in ("evaluation/cli.py", "figures.py", "cli.py", "training/train.py"):
        (tmp_path / name).write_text("changed = True\n")
        assert kernel_cache.sources_digest(tmp_path) == key, name
    for name in ("shared/constants.py", "late.py"):
        (tmp_path / name).write_text("changed = True\n")
        assert kernel_cache.sources_digest(tmp_path) != key, name
        key = kernel_cache.sources_digest(tmp_path)


def test_the_packages_kernel_sources_are_its_kernel_layers():
    """Today's package: the physics, tasks, envs, the compiled planners and the JAX host
    kernel's FFI handlers (which inline `jax/ffi.py`'s helpers), and what they import;
    evaluation, training, the figures and the XLA kernels are not among them."""
    package = Path(tether_gym.__file__).parent
    names = {path.relative_to(package).as_posix() for path in kernel_cache.kernel_sources()}
    assert {"physics/hybrid.py", "envs/tether_navigate/maneuver.py", "tasks/navigate.py",
            "agents/planner_kernels.py", "jax/ffi.py", "jax/tether_bounce/ffi.py",
            "jax/threefry.py"} <= names  # fmt: skip
    assert not {"jax/physics.py", "jax/tether_navigate/flight.py"} & names
    assert not any(name.startswith(("evaluation/", "training/")) for name in names)
    assert not {"figures.py", "cli.py", "agents/planners.py"} & names


def test_an_edited_kernel_layer_drops_every_cache(tmp_path):
    make_package(tmp_path)
    kernel_cache.refresh(tmp_path)
    caches = write_caches(tmp_path)
    (tmp_path / "physics" / "step.py").write_text("X = 2\n")
    assert kernel_cache.refresh(tmp_path)
    assert not any(path.exists() for path in caches)
    assert not kernel_cache.refresh(tmp_path)


def test_importing_the_package_records_its_sources():
    """`import tether_gym` refreshes: the digest beside the caches is that of today's sources."""
    stamp = Path(tether_gym.__file__).parent / kernel_cache.STAMP
    assert stamp.read_text() == kernel_cache.sources_digest()


def load_kernel(folder: Path, name: str = "kernel_module"):
    """A fresh import of a module holding one cached numba kernel, `plus_one`."""
    import importlib.util

    path = folder / f"{name}.py"
    if not path.exists():
        path.write_text(
            "import numba\n\n\n@numba.njit(cache=True)\ndef plus_one(x):\n    return x + 1\n"
        )
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.plus_one


def test_a_kernel_compiles_until_built_here_or_cached_on_disk(tmp_path):
    kernel = load_kernel(tmp_path)
    assert kernel_cache.compiles(kernel)
    assert kernel(1) == 2
    assert not kernel_cache.compiles(kernel)  # built in this process
    again = load_kernel(tmp_path)
    assert not again.overloads
    assert not kernel_cache.compiles(again)  # its cache is on disk


def test_a_first_run_is_announced_once(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(kernel_cache, "_ANNOUNCED", set())
    kernel = load_kernel(tmp_path)
    kernel_cache.announce("the test's kernels", kernel)
    kernel_cache.announce("the test's kernels", kernel)
    lines = capsys.readouterr().err.splitlines()
    assert lines == [
        "tether_gym: compiling the test's kernels for this machine (first run only, cached "
        "after; `tether compile` builds every kernel ahead of time)"
    ]
    kernel(1)
    kernel_cache.announce("other kernels", kernel)
    assert capsys.readouterr().err == ""


def test_tether_compile_s_parts_announce_nothing_themselves(tmp_path, capsys, monkeypatch):
    """`tether compile` says once what it compiles; its parts' kernels do not repeat it."""
    monkeypatch.setattr(kernel_cache, "_ANNOUNCED", set())
    monkeypatch.setenv(kernel_cache.QUIET, "1")
    kernel = load_kernel(tmp_path)
    assert kernel_cache.compiles(kernel)
    kernel_cache.announce("the test's kernels", kernel)
    assert capsys.readouterr().err == ""
