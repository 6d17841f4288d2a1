"""Verdicts: what a model's solution is worth against the reference and the literature.

``yardstick`` and ``errors`` measure a path's error, ``tolerance`` and ``grading`` judge it,
``cost`` estimates what a solve costs, ``recommend``, ``pick`` and ``advice`` name the model to
use, ``claims`` and ``claims_howell`` judge published validity claims, ``atlas`` and
``atlas_mech`` map each model's error over load space, ``predict`` and ``predict_table`` give
every reduced model its expected error, ``fecheck`` re-solves synthesised scenes with
``fem-auto``, and ``thesis_identify``, ``thesis_hypotheses`` and ``thesis_study`` judge the
six-bar thesis port against the thesis's own printed tables.  These modules compute
judgements from solutions; they do not schedule runs or write run directories
(``reports.run``) or draw pages (``reports.render``).
"""
