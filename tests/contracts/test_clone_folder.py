"""A clone named `tether_gym` seen from the folder that holds it (docs/getting-started.md, "The
clone's folder"): Python takes the clone for the package, an empty namespace package whose code
never runs, so `import tether_gym` cannot warn and `gym.make` says only that the id does not
exist; the clone's own `agents/`, imported as `tether_gym.agents`, says what happened."""

from __future__ import annotations

import os
import subprocess
import sys

from tests.helpers import ROOT


def _python(code: str, folder) -> subprocess.CompletedProcess:
    """`python -c code` in `folder`, which holds the clone as `tether_gym` (no PYTHONPATH: only
    the installed package and the folder Python starts in)."""
    (folder / "tether_gym").symlink_to(ROOT, target_is_directory=True)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    return subprocess.run([sys.executable, "-c", code], cwd=folder, env=env, capture_output=True,
                          text=True, timeout=120)  # fmt: skip


def test_the_clone_taken_for_the_package_says_so_where_its_code_runs(tmp_path):
    done = _python(
        "import tether_gym\n"
        "print(getattr(tether_gym, '__file__', None), list(tether_gym.__path__))\n"
        "from tether_gym.agents.registry import make_agent\n",
        tmp_path,
    )
    assert done.stdout.split()[0] == "None", done.stdout  # the namespace package, as documented
    assert done.returncode != 0
    assert "ImportError: tether_gym here is the clone, not the package" in done.stderr
    assert "Run Python inside the clone or in another folder" in done.stderr
