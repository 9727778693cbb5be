"""``python -m studies.cli``: the ``lcnav`` command line."""

import sys

from studies.cli import main

sys.exit(main())
