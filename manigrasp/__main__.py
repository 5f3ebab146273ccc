"""``python -m manigrasp``: the same as the `manigrasp` command."""

import sys

from manigrasp.cli import main

sys.exit(main())
