"""Model comparison by evidence.

Two independent estimators of log Z with different failure modes, each with its error: nested
sampling (:mod:`.nested`, dynesty with batched likelihood calls, :mod:`.batching`), by default with
its prior repartitioned onto the emcee draws (:mod:`.repartition`), and bridge sampling on the
converged emcee posterior (:mod:`.bridge`); a lower bound from the draws that catches an estimate
far too low (:mod:`.bound`); Laplace at the mode as a
screen (:mod:`.laplace`); Bayes factors on Kass & Raftery's scale (:mod:`.scale`), PSIS-LOO beside
them (:mod:`.loo`), prior sensitivity with every width doubled (:mod:`.sensitivity`), the NL ring
count by evidence beside Hankel's (:mod:`.rings`), all orchestrated by :mod:`.compare` into the
frozen records of :mod:`.records`.
"""

from .bridge import BridgeResult, bridge_evidence
from .compare import CompareSettings, compare_models, model_evidence
from .fit_evidence import Evidence, fit_log_evidence
from .laplace import LaplaceResult, laplace_evidence
from .nested import NestedRun, NestedSettings, read_nested, run_nested
from .records import Comparison, ModelEvidence
from .repartition import Repartition, RepartitionedTarget
from .rings import ring_choice, rings_by_evidence

__all__ = ["Evidence", "fit_log_evidence", "BridgeResult", "bridge_evidence", "CompareSettings",
           "compare_models", "model_evidence",
           "LaplaceResult", "laplace_evidence", "NestedRun", "NestedSettings", "read_nested", "run_nested",
           "Comparison", "ModelEvidence", "Repartition", "RepartitionedTarget", "ring_choice",
           "rings_by_evidence"]
