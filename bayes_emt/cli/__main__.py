"""``python -m bayes_emt.cli``: the command line."""

import sys

from . import main

sys.exit(main())
