"""Longest known pairs first (``reports.run.schedule``)."""

from types import SimpleNamespace

from reports.run import schedule


def _task(case, model, sweep=None):
    return {"case": case, "model": model, "scene": SimpleNamespace(sweep_parent=sweep)}


def test_known_longest_first_unknown_in_planned_order_sweep_points_last():
    tasks = [
        _task("a", "fem-auto"),
        _task("b", "replay"),
        _task("p1", "fem-auto", sweep="s"),
        _task("c", "prb-1r"),
        _task("d", "cbcm-auto"),
        _task("p2", "kinetostatic", sweep="s"),
    ]
    known = {"c|prb-1r": 0.01, "d|cbcm-auto": 30.0, "p2|kinetostatic": 5.0}
    got = [(t["case"], t["model"]) for t in schedule.order(tasks, known)]
    assert got == [
        ("d", "cbcm-auto"),
        ("c", "prb-1r"),
        ("a", "fem-auto"),
        ("b", "replay"),
        ("p2", "kinetostatic"),
        ("p1", "fem-auto"),
    ]


def test_durations_round_trip(tmp_path, monkeypatch):
    monkeypatch.setenv("FLEXBENCH_CACHE", str(tmp_path))
    recs = [
        {"case": "a", "model": "m", "timing": {"total_s": 2.0}, "exports": {"export_s": 0.5}},
        {"case": "b", "model": "m", "timing": {"total_s": 9.0}, "cached": True},
        {"case": "c", "model": "m", "status": "not-applicable"},
    ]
    schedule.write(recs)
    assert schedule.read() == {"a|m": 2.5}
