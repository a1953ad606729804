"""``python -m pnmold.cli``: the same as the ``pnmold`` command."""

import sys

from pnmold.cli import main

sys.exit(main())
