"""Fixtures shared by several test modules."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="session")
def teaching_run(tmp_path_factory):
    """One small ``run_matrix`` with its teaching page (tiny atlas grid): (out dir, result,
    the keyword arguments to run it again)."""
    import cases
    from reports import runner

    out = tmp_path_factory.mktemp("teaching-run")
    kw = dict(workers=2, progress=False, teaching=(5, 3), render_shapes=False, export=None)
    scenes = [cases.load("cantilever-tip-load")]
    res = runner.run_matrix(scenes, ["prb-1r", "bcm", "linear-8"], out, fresh=True, **kw)
    return out, res, kw
