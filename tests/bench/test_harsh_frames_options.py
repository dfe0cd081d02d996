"""scripts/validation/harsh_frames.py's nominal-FOV option: ``--fov-off F`` gives identify's
path a camera F times the true FOV (the nominal FOV searched within the default
tolerance), and refuses what it cannot mean."""

import pytest

from scripts.validation import harsh_frames


@pytest.mark.parametrize("argv, why", [
    (["--fov-off", "1.03"], "add --pipeline"),
    (["--scale", "0.8,1.6"], "add --pipeline"),
    (["--pipeline", "--fov-off", "1.03", "--scale", "0.8,1.6"], "give one of them")])
def test_options_that_need_the_pipeline_or_exclude_each_other_are_refused(argv, why, capsys):
    with pytest.raises(SystemExit) as stop:
        harsh_frames.main(["--frames", "1", *argv])
    assert stop.value.code == 2 and why in capsys.readouterr().err


def test_a_camera_told_off_in_fov_is_solved_right_through_the_pipeline(capsys):
    assert harsh_frames.main(["--frames", "4", "--seed", "3", "--methods", "pyramid",
                              "--pipeline", "--fov-off", "1.04"]) == 0
    out = capsys.readouterr().out
    assert "the camera given as 20.8 deg (1.04x)" in out
    row = next(line for line in out.splitlines() if line.startswith("pyramid"))
    solved, wrong_att, _, wrong_id = (int(v) for v in row.split()[1:5])
    assert (solved, wrong_att, wrong_id) == (4, 0, 0)
