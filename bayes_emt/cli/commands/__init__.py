"""One module per ``bayes-emt`` sub-command (discovered by :mod:`bayes_emt.cli`)."""
