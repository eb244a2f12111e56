"""Track management: left-right resolution (L-R paper section III) and multi-target tracks."""
