"""Physics of the dithered RLG channel: suspension, drive, plant, readout, motion."""
