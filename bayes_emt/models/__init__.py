"""Transducer models: pure physics kernels (``terms``), the terms that own their behaviour
(``term``, ``catalogue`` for the paper's, ``augmentations`` for SPEC §7's), the registry, the
model composed from terms, specs (``UD+winding_capacitance``) and the Foster form."""

from .model import JwForm, Loop, Model
from .rational import BESSEL_SECTIONS, Foster, foster_form
from .registry import (
           AUGMENTATIONS,
           BASE_MODELS,
           MODEL_NAMES,
           TERMS,
           catalogue_entries,
           make_term,
           term_from_dict,
)
from .spec import (
    DEFAULT_N_TURNS,
    DEFAULT_RINGS,
    EDDY_LADDER,
    build_model,
    eddy_escalations,
    model_from_dict,
    parse_model_spec,
)
from .term import CoilStart, FosterPart, StartContext, Term

__all__ = ["Model", "Loop", "JwForm",
           "Term", "CoilStart", "FosterPart", "StartContext", "TERMS", "AUGMENTATIONS",
           "BASE_MODELS", "MODEL_NAMES", "make_term", "term_from_dict", "catalogue_entries", "build_model",
           "parse_model_spec", "model_from_dict", "DEFAULT_N_TURNS", "DEFAULT_RINGS", "Foster", "foster_form",
           "BESSEL_SECTIONS", "EDDY_LADDER", "eddy_escalations"]
