"""``python -m suspopt.cli``: the command line."""

import sys

from suspopt.cli.main import main

sys.exit(main())
