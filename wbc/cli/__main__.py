"""``python -m wbc.cli``: the ``wbc`` command."""

import sys

from wbc.cli.main import main

sys.exit(main())
