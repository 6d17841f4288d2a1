"""Single-beam model families, one module per family: ``elastica`` (exact, with its state
``elastica_state``, the pendulum flow ``elastica_flow``, ``elastica_shooting`` and
``elastica_bvp``), ``linear`` (Euler-Bernoulli), ``prb``
(pseudo-rigid-body, with ``prb_chain``, ``prb_tables`` and ``prb_fit``), ``bcm`` (beam
constraint model) and chained BCM (``chain`` segment law and problem, ``chain_model``,
``chain_small``); ``single_beam`` reads a single-beam scene for all of them."""
