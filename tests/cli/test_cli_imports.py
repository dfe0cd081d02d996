"""Commands import what they use: ``--help`` and ``--version`` load neither the compiled
core nor astropy, scipy.spatial or matplotlib; and no command ever loads a JIT compiler
(the core is compiled when the package is installed)."""

from __future__ import annotations

import json
import os

from click.testing import CliRunner
from repo_paths import DATA
from waiting import run_python

from startrack.cli import main
from startrack.defaults import BUILTIN_METHODS
from startrack.io import _cache
from startrack.matchers import available_methods, registry

HEAVY = ("numba", "llvmlite", "astropy", "scipy.spatial", "matplotlib")
QUICK = [["--version"], ["--help"], *[[c, "--help"] for c in
                                      ("identify", "compare", "simulate", "calibrate",
                                       "cache")]]

# Run in a new interpreter: what other tests imported must not hide an import here.
CHILD = """
import json, sys
from click.testing import CliRunner
from startrack.cli import main
answers = []
for args in json.loads(sys.argv[1]):
    result = CliRunner().invoke(main, args)
    answers.append([args, result.exit_code, len(result.output)])
print(json.dumps({"answers": answers, "modules": sorted(sys.modules)}))
"""


def test_help_and_version_load_no_heavy_module():
    out = json.loads(run_python(CHILD, json.dumps(QUICK)))
    assert [(a, code) for a, code, _ in out["answers"]] == [(a, 0) for a in QUICK]
    assert all(n > 20 for _, _, n in out["answers"])  # each printed its help or version
    loaded = out["modules"]
    heavy = [m for m in loaded if m.split(".")[0] in HEAVY or m.startswith(HEAVY)]
    kernels = [m for m in loaded if m.startswith("startrack._core")]
    assert heavy == [] and kernels == []


def test_builtin_methods_are_the_registered_ones():
    available_methods()  # registers every built-in matcher
    # a variant (register_variant) is made in startrack.matchers._base from its base class
    ours = {name for name, cls in registry().items()
            if (cls.__mro__[1] if getattr(cls, "variant_of", None) else cls)
            .__module__.startswith("startrack.matchers.")}
    assert set(BUILTIN_METHODS) == ours


SOLVE = """
import sys
from pathlib import Path
import startrack
frame = Path(sys.argv[1])
s = startrack.solve(frame, fov_deg=11.42, sky="hipparcos", epoch=2019.6)
print(s.solved, any(m.split(".")[0] in ("numba", "llvmlite") for m in sys.modules))
"""


def test_a_solve_loads_no_jit_compiler(tmp_path):
    frame = DATA / "realsky_azi45.png"
    env = dict(os.environ, STARTRACK_CACHE_DIR=str(tmp_path))
    assert run_python(SOLVE, str(frame), env=env).split() == ["True", "False"]


def test_help_cites_what_users_have():
    """cache --help gives the cap the code uses; calibrate --help cites the shipped docs."""
    text = " ".join(CliRunner().invoke(main, ["cache", "--help"]).output.split())
    assert f"(default {_cache.DEFAULT_CACHE_MAX_MB})" in text
    assert "interfaces.md" not in text
    calibrate = " ".join(CliRunner().invoke(main, ["calibrate", "--help"]).output.split())
    assert "docs/conventions.md" in calibrate and "interfaces.md" not in calibrate


def test_a_script_beside_a_folder_named_startrack_imports_the_package(tmp_path):
    """Issue 45: run from a clone's parent, where the clone folder is named `startrack`,
    a script imported that folder (a namespace package) instead: "module 'startrack' has
    no attribute 'solve'". The editable install is a path entry (pyproject.toml's
    package-dir), which a regular package found on it wins over."""
    import subprocess
    import sys

    clone = tmp_path / "startrack"
    clone.mkdir()
    (clone / "README.md").write_text("a clone of startrack\n")
    script = tmp_path / "use.py"
    script.write_text("import startrack\nprint(startrack.solve.__module__)\n")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    run = subprocess.run([sys.executable, str(script)], cwd=tmp_path, env=env,
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    assert run.stdout.strip() == "startrack.api._solver"
