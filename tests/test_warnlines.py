"""The one-line warning hints (bayes_emt._warnlines): what an inadequate model is told to try."""

from bayes_emt._warnlines import short_hint

_ADVICE = ("the residuals are up to 12 times the noise level the data show (0.1 % of |Y| there); try: near "
           "the mechanical resonance: a second resonance (a vented box or passive radiator: enclosure_port; "
           "a rocking or fixture mode: second_resonance) or suspension creep")


def test_the_hint_names_the_advised_terms():
    assert short_hint("model_inadequate", f"UD cannot describe these data: {_ADVICE}") == (
        "residuals up to 12x the noise; try enclosure_port, second_resonance")


def test_the_hint_does_not_advise_a_term_the_model_holds():
    """A model holding enclosure_port is not told to try it (its label opens the message)."""
    hint = short_hint("model_inadequate", f"NL(3)+enclosure_port cannot describe these data: {_ADVICE}")
    assert hint == "residuals up to 12x the noise; try second_resonance"
