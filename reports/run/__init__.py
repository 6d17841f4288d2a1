"""Running the benchmark: the case x model matrix solved, timed, bounded, kept and compared.

``runner`` plans and executes the matrix (``run_matrix``), ``sweep`` expands sweep cases into
rows, ``timing`` and ``limits`` measure and bound one solve, ``progress`` tells the person
waiting, ``journal`` and ``store`` keep every finished pair (``partial.jsonl``,
``results.json``/``.csv``, ``history.sqlite``), ``history`` reads the runs back, ``compare``
checks one run against another, ``tables`` and ``exports`` write the files beside the results
(CSV tables, ParaView series, the replay animation), ``overlap`` draws per-case figures while
the run still solves and ``teach_run`` computes the teaching page's atlases as pool jobs of
the same run.  These modules decide *when and where* things are solved and written; what a
solution is worth is ``reports.verdicts``'s business.
"""
