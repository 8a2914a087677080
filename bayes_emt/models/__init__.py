"""Transducer models: pure physics terms, the term catalogue and the model registry."""

from .catalogue import TERMS, Term, make_term
from .model import DEFAULT_N_TURNS, DEFAULT_RINGS, MODEL_NAMES, Model, build_model

__all__ = ["TERMS", "Term", "make_term", "Model", "build_model", "MODEL_NAMES", "DEFAULT_N_TURNS",
           "DEFAULT_RINGS"]
