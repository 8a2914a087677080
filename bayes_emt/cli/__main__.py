"""``python -m bayes_emt.cli``: the command line."""

import os
import signal
import sys


def _quit_while_importing(signum, frame):  # pragma: no cover - timing dependent
    # a signal while numpy & co. are imported: one line, no traceback (main() installs its own)
    os.write(2, b"bayes-emt: interrupted\n")
    os._exit(128 + signum)


signal.signal(signal.SIGINT, _quit_while_importing)
signal.signal(signal.SIGTERM, _quit_while_importing)

from . import main  # noqa: E402

sys.exit(main())
