"""Progress bars: a finished stage stays on stderr, a failed one goes (its error line follows alone)."""
import pytest

from patchlight.errors import PatchlightError
from patchlight.progress import Progress


def test_a_stage_that_fails_takes_its_bar_away(capsys):
    with pytest.raises(PatchlightError):
        with Progress() as progress:
            with progress.stage("finished", total=3) as advance:
                advance(3)
            with progress.stage("failing", total=3) as advance:
                advance()
                raise PatchlightError("the input is wrong")
    err = capsys.readouterr().err
    assert "finished" in err and "3/3" in err
    assert "failing" not in err
    assert set(progress.seconds) == {"finished", "failing"}  # both timed all the same
