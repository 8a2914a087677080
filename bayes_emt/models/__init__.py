"""Transducer models: pure physics kernels (``terms``), the terms that own their behaviour
(``term``, ``catalogue`` for the paper's, ``physics/`` for the catalogue's, one per module), the
registry (``register_term`` for a term defined elsewhere), the model composed from terms, specs
(``UD+winding_capacitance``) and the Foster form."""

from .model import JwForm, Loop, Model
from .rational import BESSEL_SECTIONS, Foster, foster_form
from .registry import (
           AUGMENTATIONS,
           BASE_MODELS,
           MODEL_NAMES,
           TERMS,
           augmentations_in_band,
           catalogue_entries,
           make_term,
           param_spec,
           register_term,
           term_from_dict,
           unregister_term,
)
from .spec import (
    DEFAULT_N_TURNS,
    DEFAULT_RINGS,
    EDDY_BAND,
    EDDY_LADDER,
    EDDY_PHYSICS,
    build_model,
    eddy_escalations,
    model_from_dict,
    parse_model_spec,
)
from .term import BANDS, CoilStart, FosterPart, StartContext, Term

__all__ = ["Model", "Loop", "JwForm",
           "Term", "CoilStart", "FosterPart", "StartContext", "BANDS", "TERMS", "AUGMENTATIONS",
           "BASE_MODELS", "MODEL_NAMES", "make_term", "term_from_dict", "catalogue_entries", "build_model",
           "register_term", "unregister_term", "param_spec", "augmentations_in_band",
           "parse_model_spec", "model_from_dict", "DEFAULT_N_TURNS", "DEFAULT_RINGS", "Foster", "foster_form",
           "BESSEL_SECTIONS", "EDDY_LADDER", "EDDY_PHYSICS", "EDDY_BAND", "eddy_escalations"]
