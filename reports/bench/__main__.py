"""``python -m reports.bench``: the speed record (``reports.bench.speed``)."""

import sys

from reports.bench.speed import main

sys.exit(main())
