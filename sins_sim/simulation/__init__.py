"""The engine: wires models -> readout -> filters (and later navigation)."""
