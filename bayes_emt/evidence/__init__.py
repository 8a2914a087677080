"""Model comparison by evidence: log Z by nested sampling (dynesty, prior to posterior), bridge
sampling on the emcee posterior and Laplace at the optimum; Bayes factors, PSIS-LOO beside them,
prior sensitivity and the NL ring count by evidence."""
