"""Digital signal processing shared by the stages and the simulator: FFT plans, windows and
array shading, framing, fractional delay, peak picking, noise normalisation, worker threads."""
