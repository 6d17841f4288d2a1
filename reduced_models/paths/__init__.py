"""Path following for the reduced models: load stepping, Newton, step cuts and branch watch
(``continuation``; ``small_path`` and ``scalar_path`` for tiny systems in plain floats), the
``PathResult`` they return and the banded linear algebra (``linalg``) they solve with."""
