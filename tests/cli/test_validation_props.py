"""Property test of the validation layer: random values and types thrown at every numeric
option of every command, every numeric environment variable and every API keyword.

Each CLI probe runs in-process (click's runner, the same group and error handling as the
installed command) with an input that cannot be read, so a value that passes validation
stops at that input: either way the answer must be exit 2 with one stderr line, no
traceback and no output file. A value outside the option's documented bounds must be named
in that line. Derandomized: the same examples every run.
"""

from __future__ import annotations

import math

import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from startrack.cli import main
from startrack.cli._shared_options import Number
from startrack.input_checks import Bounds

PROBES = settings(max_examples=120, derandomize=True, deadline=None, database=None,
                  suppress_health_check=[HealthCheck.function_scoped_fixture])

NUMBERS = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-10**40, max_value=10**40),
    st.floats(min_value=-1e-3, max_value=1e-3),
)
TEXTS = st.one_of(
    st.sampled_from(["nan", "inf", "-inf", "1e400", "-1e400", "1e-300", "0", "-0", "-1",
                     "1e200", "abc", "", " ", "1,2", "1,2,3", "0x10", "1_000", "3.5e",
                     "nan,0,0", "1e300,0,0", "0,1e300,0", "2016-12-31T23:59:60.5"]),
    st.text(alphabet=st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00"),
            max_size=12),
)
VALUES = st.one_of(NUMBERS.map(repr), NUMBERS.map(str), TEXTS)

# (command, its options that take a number or numbers, arguments that make it stop at an
# unreadable input after validation; "{tmp}" is the test's folder)
COMMANDS = {
    "identify": (["--fov", "--fov-tolerance", "--mag-limit", "--epoch", "--max-stars",
                  "--sigma-px", "--timeout-ms", "--prior-sigma-deg", "--size", "--prior",
                  "--time"],
                 ["{tmp}/missing.png", "--output", "{tmp}/out.json", "--corr",
                  "{tmp}/corr.csv"]),
    "calibrate": (["--fov", "--terms", "--mag-limit", "--epoch", "--size"],
                  ["{tmp}/missing.png", "--output", "{tmp}/camera.json"]),
    "simulate": (["--mag-limit", "--frames", "--seed", "--false-stars", "--missing",
                  "--mag-noise", "--fps", "--rate", "--attitude", "--time"],
                 ["--config", "{tmp}/missing.toml", "--out", "{tmp}/sim"]),
    "compare": (["--mag-limit", "--frames", "--max-stars", "--threshold-arcsec", "--jobs",
                 "--seed", "--fps", "--noise-px", "--false-stars", "--missing", "--mag-noise",
                 "--fov-error", "--distortion", "--modelled-distortion", "--rates"],
                ["--config", "{tmp}/missing.toml", "--out", "{tmp}/cmp"]),
}
PROBES_RUN = {"cli": 0, "env": 0, "api": 0}


def _option_bounds(command: str, option: str) -> Bounds | None:
    for param in main.commands[command].params:
        if option in param.opts and isinstance(param.type, Number):
            return param.type.bounds
    return None


def _outside(text: str, bounds: Bounds) -> bool:
    """True when ``text`` is a finite number outside ``bounds`` (or not finite)."""
    try:
        value = float(text)
    except ValueError:
        return False
    return not math.isfinite(value) or value not in bounds


def _invoke(args: list[str], env: dict | None = None):
    return CliRunner().invoke(main, args, env=env, catch_exceptions=False)


def _check_one_line(result, tmp_path) -> str:
    lines = result.stderr.splitlines()
    assert result.exit_code == 2, (result.exit_code, result.stderr)
    assert len(lines) == 1, result.stderr
    assert "Traceback" not in result.stderr and "Warning" not in result.stderr
    left = {p.name for p in tmp_path.iterdir()}
    assert not left, left  # no output file, folder or temporary file
    return lines[0]


@pytest.mark.parametrize("command", sorted(COMMANDS))
@PROBES
@given(data=st.data())
def test_every_numeric_option_answers_in_one_line(command, data, tmp_path):
    options, base = COMMANDS[command]
    option = data.draw(st.sampled_from(options), label="option")
    value = data.draw(VALUES, label="value")
    args = [command, *(a.format(tmp=tmp_path) for a in base), f"{option}={value}"]
    line = _check_one_line(_invoke(args), tmp_path)
    PROBES_RUN["cli"] += 1
    bounds = _option_bounds(command, option)
    if bounds is not None and _outside(value, bounds):
        assert option in line, line  # the message names its source


ENV_VARS = ["STARTRACK_CACHE_MAX_MB", "STARTRACK_MAX_IMAGE_PIXELS", "STARTRACK_MAX_PAIRS"]


@PROBES
@given(name=st.sampled_from(ENV_VARS), value=VALUES)
def test_numeric_environment_answers_in_one_line(name, value, tmp_path_factory):
    if "\x00" in value:
        return
    result = _invoke(["cache", "info"], env={name: value})
    PROBES_RUN["env"] += 1
    assert "Traceback" not in result.stderr
    if result.exit_code != 0:
        assert result.exit_code == 2
        assert len(result.stderr.splitlines()) == 1 and name in result.stderr


API_KEYWORDS = ["fov_deg", "fov_tolerance", "sigma_px", "mag_limit", "epoch", "max_stars",
                "timeout_ms", "prior_sigma_deg", "time", "prior", "size", "camera"]
API_VALUES = st.one_of(
    NUMBERS, TEXTS, st.booleans(), st.none(),
    st.tuples(NUMBERS, NUMBERS), st.tuples(NUMBERS, NUMBERS, NUMBERS),
    st.lists(NUMBERS, max_size=4),
    st.dictionaries(st.sampled_from(["width", "height", "fov_deg", "cx", "cy", "bogus"]),
                    st.one_of(NUMBERS, TEXTS, st.booleans()), max_size=4),
)


@settings(max_examples=300, derandomize=True, deadline=None, database=None)
@given(keyword=st.sampled_from(API_KEYWORDS), value=API_VALUES)
def test_every_api_keyword_is_taken_or_refused_cleanly(keyword, value):
    import startrack

    PROBES_RUN["api"] += 1
    options = {"fov_deg": 17.5, "sky": "random", keyword: value}
    if keyword == "camera":
        options.pop("fov_deg")
    try:
        startrack.Solver(**options)
    except (ValueError, TypeError, FileNotFoundError) as exc:  # a path to no camera file
        assert "\n" not in str(exc) and str(exc)
