"""Model comparison by evidence (issue 11).

Two independent estimators of log Z with different failure modes, each with its error: nested
sampling from the prior (:mod:`.nested`, dynesty with batched likelihood calls, :mod:`.batching`)
and bridge sampling on the converged emcee posterior (:mod:`.bridge`); Laplace at the mode as a
screen (:mod:`.laplace`); Bayes factors on Kass & Raftery's scale (:mod:`.scale`), PSIS-LOO beside
them (:mod:`.loo`), prior sensitivity with every width doubled (:mod:`.sensitivity`), the NL ring
count by evidence beside Hankel's (:mod:`.rings`), all orchestrated by :mod:`.compare` into the
frozen records of :mod:`.records`.
"""

from .bridge import BridgeResult, bridge_evidence
from .compare import CompareSettings, compare_models, model_evidence
from .laplace import LaplaceResult, laplace_evidence
from .nested import NestedRun, NestedSettings, read_nested, run_nested
from .records import Comparison, ModelEvidence
from .rings import ring_choice, rings_by_evidence

__all__ = ["BridgeResult", "bridge_evidence", "CompareSettings", "compare_models", "model_evidence",
           "LaplaceResult", "laplace_evidence", "NestedRun", "NestedSettings", "read_nested", "run_nested",
           "Comparison", "ModelEvidence", "ring_choice", "rings_by_evidence"]
