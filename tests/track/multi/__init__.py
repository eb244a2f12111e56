"""Tests of the multi-target tracker package (track/multi)."""
