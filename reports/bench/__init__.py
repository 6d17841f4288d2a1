"""Benchmarks: the speed record against limits and peers (``python -m reports.bench``,
``speed.py``), the mechanism and FE/replay comparisons (``mech``, ``fem``, ``replay``), and the
memory and browser probes (``treemem``, ``browser``)."""
