"""Deterministic estimation: pre-fit checks, the automatic initial estimate, the two-step weighted
least squares (SPEC §3) and its frozen result, and the Hankel ring count."""
