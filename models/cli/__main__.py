"""``python -m models.cli``: the ``hbg`` command."""

import sys

from .main import main

sys.exit(main())
