"""Deterministic estimation: pre-fit checks, the automatic initial estimate, the two-step weighted
least squares and its frozen result, and the Hankel ring count."""
