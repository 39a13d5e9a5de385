"""The accelerometer triad: velocity increments of specific force, quantised as pulse counts.

Body axes x, y, z are the gyros' sensitive axes and the accelerometers'
(docs/theory/navigation.md). Each accelerometer integrates specific force and its converter emits a pulse
per ``quantum_m_s`` of velocity (a current-to-frequency converter). The output over a filter
sample is the number of pulses in that sample times the quantum: the accumulated count
``floor(V(t_k) / q)`` is differenced, so the quantisation error of each output is carried
into the next one and never accumulates (the velocity read off the counts is the true
integral rounded to the nearest pulse, within half a quantum; Savage, *Strapdown Analytics*, 2nd ed., 2007, sec. 7.1.2.3,
on integrating sensors with pulse outputs).

The input is the exact integral of specific force over each sample, supplied by the mission
truth (:mod:`sins_sim.simulation.truth`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sins_sim import _validate as v
from sins_sim._kernels import sensors as ksens

__all__ = ["AccelerometerParams", "Accelerometer", "DEFAULT_VELOCITY_QUANTUM_M_S"]

#: Velocity per pulse (m/s): 0.1 mm/s, of the order of navigation-grade accelerometer
#: converters (a setting of the unit, stated rather than sourced; 0 switches quantisation off).
DEFAULT_VELOCITY_QUANTUM_M_S = 1e-4


@dataclass(frozen=True)
class AccelerometerParams:
    """Accelerometer triad parameters.

    Parameters
    ----------
    quantum_m_s : float
        Velocity per output pulse (m/s), >= 0 (0: no quantisation).
    """

    quantum_m_s: float = DEFAULT_VELOCITY_QUANTUM_M_S

    def __post_init__(self):
        q = v.non_negative("accelerometer", "quantum_m_s", self.quantum_m_s)
        if q > 1.0:
            raise ValueError(f"accelerometer.quantum_m_s: must be <= 1 m/s (a pulse weight), got {q!r}")


class Accelerometer:
    """Streaming accelerometer triad: exact velocity increments in, quantised increments out.

    Parameters
    ----------
    params : AccelerometerParams
    rng : numpy.random.Generator or None
        Source of the sensor-error draws (reserved for the sensor error model; the pulse
        quantisation itself is deterministic).
    """

    def __init__(self, params: AccelerometerParams, rng: np.random.Generator | None = None):
        if not isinstance(params, AccelerometerParams):
            raise ValueError(f"accelerometer: must be AccelerometerParams, got {type(params).__name__}")
        self.params = params
        self.rng = rng
        # velocity accumulated below one pulse, in pulses; starting at half a pulse makes the accumulated
        # output the true velocity rounded to the nearest pulse (error within +-q/2, zero mean)
        self._frac = np.full(3, 0.5)

    def process(self, dv_true) -> np.ndarray:
        """Quantised velocity increments (m/s) for a chunk of exact increments ``dv_true`` (N, 3) (m/s)."""
        dv = np.asarray(dv_true, dtype=np.float64)
        if dv.ndim != 2 or dv.shape[1] != 3:
            raise ValueError(f"accelerometer.dv_true: must have shape (N, 3), got {dv.shape}")
        q = self.params.quantum_m_s
        if q == 0.0:
            return dv.copy()
        pulses = np.empty_like(dv)
        ksens.pulse_quantise(np.ascontiguousarray(dv / q), self._frac, pulses)
        return pulses * q
