"""``python -m handarm.cli``: the same as the ``handarm`` command."""

import sys

from handarm.cli import main

sys.exit(main())
