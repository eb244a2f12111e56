"""Passive displays and measurements from beams: integration, BTR, LOFAR, bearings, band power."""
