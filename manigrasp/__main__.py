"""``python -m manigrasp``: the same as the `manigrasp` command."""

import sys

try:
    from manigrasp.cli import main
except KeyboardInterrupt:  # a Ctrl-C before `main` runs: as in it, one line and 130, not an import traceback
    sys.stderr.write("manigrasp: interrupted\n")
    sys.exit(130)

sys.exit(main())
