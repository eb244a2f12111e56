"""Interoperability with other tracking and analysis packages (optional extras)."""
