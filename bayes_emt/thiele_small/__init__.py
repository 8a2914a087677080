"""Thiele–Small parameters with credible intervals: free air, added mass (one or
several masses in one joint posterior), added volume; the loudspeaker engineer's bench workflow.
Sits beside :mod:`bayes_emt.discovery`, above the features it uses (added mass, inference,
estimation)."""

from .compute import from_fit, from_posterior, thiele_small
from .model_free import ModelFree, ModelFreeUndefined, model_free_ts
from .relations import NAMES, UNITS
from .result import ThieleSmall, read_thiele_small

__all__ = ["thiele_small", "from_fit", "from_posterior", "ThieleSmall", "read_thiele_small", "NAMES", "UNITS",
           "model_free_ts", "ModelFree", "ModelFreeUndefined"]
