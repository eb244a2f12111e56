"""Beamforming stages: conventional (CBF), inverse beamforming, ETAM synthetic aperture."""
