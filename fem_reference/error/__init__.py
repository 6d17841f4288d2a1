"""Error estimation of the FE reference: Richardson extrapolation, observed order and the
one two-mesh rule ``gci`` (``richardson``), and per-member mesh refinement (``adaptive``)."""
