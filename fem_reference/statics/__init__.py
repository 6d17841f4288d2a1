"""Static solution of the FE system: Newton and load/displacement control (``newton``,
``static``), arc-length (``arclength``), bifurcation watch and branch switch
(``bifurcation``), integrity checks (``integrity``), driver outputs (``driver_post``) and the
static boom deployment (``deploy``)."""
