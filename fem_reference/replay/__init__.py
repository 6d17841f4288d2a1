"""The damped dynamics replay (the ``replay`` model, ``model``): the generalised-alpha
integrator (``integrator``, band-storage step ``band``), the loading programme that ramps,
holds, settles and probes (``run``), the driver moved as a motion (``driver``), the servo that
holds a coordinate (``servo``), boom lock events (``events``) and deployment (``deploy``) and
what the replay says about itself (``honesty``)."""
