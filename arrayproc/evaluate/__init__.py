"""Evaluation: Monte Carlo drivers, the papers' scenarios, and metrics against truth."""
