"""``python -m mjchar``: the ``mjchar`` command line."""

import sys

from mjchar.cli import main

sys.exit(main())
