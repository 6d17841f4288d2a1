"""Published claims judged on their own terms (``reports.verdicts.claims``, ``flexbench claims``).

Howell's metric is checked on tips with a known answer (on and off the characteristic-radius
circle), then on the exact elastica against Howell's own published numbers: at n = 0 his
Theta_max = 64.3 deg is *defined* as the angle where the error reaches 0.5 %, so our
evaluation must find the 0.5 % crossing within the table's rounding of 64.3 deg and the error
at 64.3 deg within the rounding of 0.5 %.  The force atlas of the ``ours`` readings is computed
on a coarse 8 x 9 grid here: the tests check the record's shape and that our reading is
labelled as ours, not the atlas's figures (``tests/test_atlas.py`` checks those).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from reduced_models.beam import prb_tables as T
from reports import cli
from reports.verdicts import atlas, claims, claims_howell

GAMMA0 = T.HOWELL_N0["gamma"]
THETA0 = T.HOWELL_N0["Theta_max_deg"]
SMALL_GRID = (8, 9)
FIELDS = {"id", "model", "source", "claim", "metric", "region", "parameters", "claimed"}
FIELDS |= {"worst", "at", "verdict", "note", "ours"}


def test_howell_metric_is_zero_on_the_circle_and_exact_off_it():
    theta = np.radians([5.0, 30.0, 64.3, 100.0])
    pivot = np.array([1.0 - GAMMA0, 0.0])
    ring = pivot + GAMMA0 * np.c_[np.cos(theta), np.sin(theta)]
    th, err = claims_howell.howell_error(ring, GAMMA0)
    assert th == pytest.approx(np.degrees(theta), abs=1e-12)
    assert np.abs(err).max() < 1e-14
    # a tip d outside the circle: radial error d over its distance from the undeflected tip
    d = 0.01
    off = pivot + (GAMMA0 + d) * np.c_[np.cos(theta), np.sin(theta)]
    expected = d / np.hypot(off[:, 0] - 1.0, off[:, 1])
    assert claims_howell.howell_error(off, GAMMA0)[1] == pytest.approx(expected, rel=1e-12)


def test_howell_theta_max_at_n0_is_where_the_error_reaches_half_a_percent():
    # Howell's definition of Theta_max, recomputed: the tabulated 64.3 deg within its rounding
    p = claims_howell._load_at_last_crossing(0.0, GAMMA0, 5e-3)
    theta = claims_howell.howell_error(claims_howell._tips(0.0, p), GAMMA0)[0][0]
    assert theta == pytest.approx(THETA0, abs=claims_howell.THETA_ROUNDING_DEG + 0.01)
    row = claims_howell.howell_row(0.0, GAMMA0, THETA0)
    assert row["at"]["Theta_deg"] == pytest.approx(THETA0, abs=1e-9)  # worst at the limit
    assert 5e-3 < row["worst"] < 5.1e-3  # 0.504 %: Theta_max is rounded to 0.1 deg
    assert row["worst_within_rounding"] <= 5e-3 and row["verdict"] == "holds"


def test_fitted_gamma_instead_of_the_table_fails_howell():
    # planted bug: our curve-fit gamma (0.852144) in place of Table 5.1's 0.8517 moves the
    # worst point to an interior bump and breaks the claim even within the table's rounding
    row = claims_howell.howell_row(0.0, T.howell_gamma(0.0), THETA0)
    assert row["verdict"] == "fails" and row["worst_within_rounding"] > 5e-3
    assert row["at"]["Theta_deg"] < 45.0


@pytest.fixture(scope="module")
def records(tmp_path_factory):
    """``flexbench claims --json`` on a coarse atlas, cached in a temporary directory."""
    mp = pytest.MonkeyPatch()
    mp.setenv("FLEXBENCH_CACHE", str(tmp_path_factory.mktemp("cache")))
    mp.setattr(claims, "ATLAS_GRID", SMALL_GRID)
    yield mp
    mp.undo()


def run_cli(capsys, *args: str) -> tuple[int, str, str]:
    rc = cli.main(["claims", *args])
    out, err = capsys.readouterr()
    return rc, out, err


def test_cli_json_shape_and_howell_record(records, capsys):
    rc, out, _ = run_cli(capsys, "--json")
    assert rc == 0
    data = json.loads(out)
    ids = [r["id"] for r in data["claims"]]
    assert ids == [c.id for c in claims.CLAIMS]
    for r in data["claims"]:
        assert FIELDS <= set(r)
        assert r["verdict"] in claims.VERDICTS
        assert isinstance(r["claim"], str) and r["claim"]
        if r["ours"] is not None:
            assert FIELDS - {"ours"} <= set(r["ours"])
            assert "our test" in r["ours"]["claim"] and "our test" in r["ours"]["source"]
    howell = data["claims"][0]
    assert howell["id"] == "howell-prb-1r" and howell["verdict"] == "holds"
    assert howell["at"]["n"] == 0.0 and howell["at"]["Theta_deg"] == pytest.approx(THETA0)
    assert howell["parameters"]["gamma"] == GAMMA0  # the table's, not our fit
    assert [row["n"] for row in howell["rows"]] == T.HOWELL_TABLE_N.tolist()
    assert all(r["verdict"] == "holds" for r in howell["rows"])
    # the rows' Theta_max grows with the compressive load ratio, as in Howell's table
    assert np.all(np.diff([row["Theta_max_deg"] for row in howell["rows"]]) > 0)
    # between rows (linear interpolation of the table): within the 0.57 % an independent
    # check found over -1.5 <= n <= 10 (issue 19), and above 0.5 % somewhere (the reason
    # Howell tabulates per n)
    mid = [r["worst"] for r in howell["between_rows"]]
    assert 5e-3 < max(mid) <= 5.7e-3
    su = data["claims"][1]
    assert su["verdict"] == "cannot-check" and su["worst"] is None and "four-bar" in su["note"]
    assert math.isclose(su["claimed"], 0.012)


def test_cli_reads_its_cache_and_prints_a_table(records, capsys, monkeypatch):
    run_cli(capsys, "--json")  # computed once (or already) per code version

    def no_recompute(*_a, **_k):
        raise AssertionError("recomputed despite the cache")

    monkeypatch.setattr(claims, "force_atlas", no_recompute)
    rc, out, _ = run_cli(capsys)
    assert rc == 0
    first = out.splitlines()[2]
    assert first.split()[:3] == ["howell-prb-1r", "prb-1r", "holds"]
    assert "our test" in out


def test_cli_unknown_claim_is_one_line_exit_2(capsys):
    rc, out, err = run_cli(capsys, "--id", "nope")
    assert rc == 2 and out == ""
    assert err.count("\n") == 1 and "nope" in err


def test_teaching_atlas_carries_the_records(records):
    at = atlas.compute("force", ("prb-1r", "bcm"), *SMALL_GRID)
    from reports.render import teaching

    data = teaching.atlas_data(at)
    assert [r["id"] for r in data["published"]] == [c.id for c in claims.CLAIMS]
    # our atlas tests are labelled ours and linked to a record
    for c in atlas.CLAIMS:
        assert c.label.startswith("our test") and c.claim_id in {r.id for r in claims.CLAIMS}
