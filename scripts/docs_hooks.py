"""MkDocs hook (``mkdocs.yml`` ``hooks:``): where the tutorials find the real recordings.

The notebook ``real_loudspeaker_added_mass`` reads two real recordings that are not shipped with
bayes_emt (``../shared/realdata`` beside a clone, or ``$BAYES_EMT_REALDATA``). When they are here the
hook points the executing kernel at them; when they are not, that one notebook is rendered without
executing it (said once in the build log) instead of failing the whole build.
"""

from __future__ import annotations

import logging
import os
from pathlib import Path

log = logging.getLogger("mkdocs.hooks.bayes_emt")
ROOT = Path(__file__).resolve().parents[1]
NEEDS_REALDATA = "tutorials/real_loudspeaker_added_mass.ipynb"
PROBE = "dayton_LS10-44_freeair_run2.txt"


def on_config(config):
    os.environ.setdefault("MPLBACKEND", "Agg")
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    real = Path(os.environ.get("BAYES_EMT_REALDATA") or ROOT.parent / "shared" / "realdata")
    jupyter = config.plugins.get("mkdocs-jupyter")
    if (real / PROBE).exists():
        os.environ["BAYES_EMT_REALDATA"] = str(real)
    elif jupyter is not None and jupyter.config.get("execute"):
        ignore = list(jupyter.config.get("execute_ignore") or [])
        jupyter.config["execute_ignore"] = [*ignore, NEEDS_REALDATA]
        log.info("real recordings not found at %s: %s is shown without running it", real, NEEDS_REALDATA)
    return config
