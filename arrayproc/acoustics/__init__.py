"""Ocean acoustics shared by the simulator, the stages and the trackers: transmission loss
(tables, BELLHOP, RAM, closed forms), source-level models and transmitted waveforms."""
