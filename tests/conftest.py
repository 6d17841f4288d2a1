"""Test-session set-up: one BLAS thread, as in the runner's workers and ``flexbench solve``;
fixtures shared by several test modules.

The suite's linear algebra is small and banded, far below threaded BLAS's break-even; on the
2-core CI machine threaded OpenBLAS made single FE solves up to 80x slower.  The variables
cover BLAS libraries loaded later (scipy ships its own OpenBLAS); ``pin_blas`` the loaded ones.
"""

import os

import pytest

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

from reports.run import timing  # noqa: E402  (after the variables, so a BLAS loaded now obeys)

timing.pin_blas()


@pytest.fixture(scope="session", autouse=True)
def cost_cache(tmp_path_factory):
    """Cost estimates (``reports.verdicts.cost``) of the whole session go to a temporary directory,
    never to the user's ``~/.cache/flexbench``."""
    with pytest.MonkeyPatch.context() as mp:
        path = tmp_path_factory.mktemp("flexbench-cache")
        mp.setenv("FLEXBENCH_CACHE", str(path))
        # every test solves its references itself (tests/test_refcache.py turns it back on)
        mp.setenv("FLEXBENCH_NO_PAIR_CACHE", "1")
        yield path


@pytest.fixture(scope="session")
def teaching_run(tmp_path_factory):
    """One small ``run_matrix`` with its teaching page (tiny atlas grid): (out dir, result,
    the keyword arguments to run it again)."""
    import cases
    from reports.run import runner

    out = tmp_path_factory.mktemp("teaching-run")
    kw = dict(workers=2, progress=False, teaching=(5, 3), render_shapes=False, export=None)
    scenes = [cases.load("cantilever-tip-load")]
    res = runner.run_matrix(scenes, ["prb-1r", "bcm", "linear-8"], out, fresh=True, **kw)
    return out, res, kw


@pytest.fixture
def pick_a_mirror_branch(monkeypatch):
    """The FE's and the replay's branch switch at a perfect structure's bifurcation with
    the tie policy off: the mode's + branch is taken (``bifurcation.Watch._switch``'s first
    sign, the replay's kick) instead of staying on the fundamental branch between the two
    mirror branches (``Watch._stay_tied``, ``sweep.mirror_sides``).  For tests that verify
    the switch itself -- the branch it lands on, against a closed form -- on a perfect scene."""
    from fem_reference.replay import sweep
    from fem_reference.statics import bifurcation

    switch = bifurcation.Watch._switch

    def first_branch(self, *args):
        new = switch(self, *args)
        self.tied = False
        return new

    monkeypatch.setattr(bifurcation.Watch, "_switch", first_branch)
    monkeypatch.setattr(sweep, "TIE_PARITY", -1.0)
