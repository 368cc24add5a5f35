"""``python -m lodkit``: the same as the ``lodkit`` command."""
import sys

from .cli import main

if __name__ == "__main__":
    sys.exit(main())
