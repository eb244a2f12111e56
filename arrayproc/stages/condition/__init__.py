"""Conditioning of the hydrophone time series before beamforming (DFT filter)."""
