"""Build startrack's compiled core: every ``startrack/_core/**/*.pyx`` (one folder per stage)
becomes one extension module, compiled by Cython and the system's C compiler when the package is
installed
(``pip install -e .``), so no kernel is compiled while a user waits.

Everything else about the package (metadata, dependencies, data files) is in
``pyproject.toml``; setuptools needs this file only for the extensions' list.
"""

import os
from pathlib import Path

import numpy as np
from Cython.Build import cythonize
from setuptools import Extension, setup

CORE = Path("startrack") / "_core"

# The modules are translated and compiled side by side, one per core this build may use:
# each is independent, so the install's work is shared among the machine's cores.
JOBS = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1

# Bounds and negative indices are checked by the Python callers that build the arrays;
# inside a kernel every index is computed, so the checks would only cost time.
DIRECTIVES = {
    "language_level": 3,
    "boundscheck": False,
    "wraparound": False,
    "initializedcheck": False,
    "embedsignature": True,
}


# Built for the machine that runs it (as numba compiled for it): its vector instructions
# make the pixel loops markedly faster (scripts/bench/bench_centroid.py). STARTRACK_PORTABLE=1
# builds for any CPU of the architecture instead.
_NATIVE = [] if os.environ.get("STARTRACK_PORTABLE") else ["-march=native"]


def _extension(source: Path) -> Extension:
    return Extension(
        ".".join(source.with_suffix("").parts),
        [str(source)],
        include_dirs=[np.get_include(), str(CORE)],
        define_macros=[("NPY_NO_DEPRECATED_API", "NPY_1_7_API_VERSION")],
        # No -ffast-math and no fused multiply-add (whose single rounding a native target
        # would otherwise allow): the kernels must round as numpy does, so that the
        # compiled and the reference results agree to the last bit.
        extra_compile_args=["-O3", "-ffp-contract=off", *_NATIVE],
    )


setup(
    ext_modules=cythonize(
        [_extension(p) for p in sorted(CORE.rglob("*.pyx"))],
        compiler_directives=DIRECTIVES,
        include_path=[str(CORE)],
        nthreads=JOBS if JOBS > 1 else 0,
    ),
    options={"build_ext": {"parallel": JOBS}},
)
