"""The plain log says something at least every ``LOG_EVERY_S`` (``reports.run.progress``)."""

import io

from reports.run import progress


def test_a_line_after_a_quiet_spell_even_between_tenths():
    log = io.StringIO()
    bar = progress.Progress(100, stream=log)
    bar.update()  # 1 % done, just started: no line
    assert log.getvalue() == ""
    bar.last_line -= progress.LOG_EVERY_S  # as if the first pair had taken that long
    bar.update()
    assert log.getvalue().count("\n") == 1 and "2/100 pairs" in log.getvalue()
    bar.update()  # right after a line: quiet again
    assert log.getvalue().count("\n") == 1
