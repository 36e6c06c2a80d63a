"""``python -m occrl.cli`` is the ``occrl`` command."""

import sys

from occrl.cli import main

if __name__ == "__main__":
    sys.exit(main())
