"""The hysteresis-regime warning (issue 12, point 7): silent on a quiet unit, still there under vibration.

The correcting filter's D carries the readout quantum amplified by eq. 5's Nyquist gain (about 34), so it
wiggles through spurious turning points a few arcsec apart; the regime counter confirms a turning point
only after a swing of 10 arcsec (a Schmitt trigger, ``sins_sim._kernels.physics.hyst_turn``)."""

import warnings

import pytest

from sins_sim.errors import HysteresisRegimeWarning
from sins_sim.models.drive import DriveParams
from sins_sim.models.motion import SineMotion
from sins_sim.models.readout import ReadoutParams
from sins_sim.models.suspension import PAPER_SUSPENSION
from sins_sim.simulation.channel import ChannelConfig, simulate_channel
from sins_sim.units import ARCMIN, ARCSEC


@pytest.mark.parametrize("f0_hz, amplitude_arcmin, noise_arcsec", [(300.0, 0.5, 0.0), (386.0, 3.0, 0.05),
                                                                   (450.0, 1.0, 0.1)])
def test_quiet_unit_at_rest_draws_no_regime_warning(f0_hz, amplitude_arcmin, noise_arcsec):
    cfg = ChannelConfig(suspension=PAPER_SUSPENSION.replace(f0_hz=f0_hz),
                        drive=DriveParams(amplitude_rad=amplitude_arcmin * ARCMIN),
                        readout=ReadoutParams(noise_rad=noise_arcsec * ARCSEC))
    with warnings.catch_warnings():
        warnings.simplefilter("error", HysteresisRegimeWarning)
        simulate_channel(cfg, 2.0, seed=1)


def test_vibration_that_sets_the_turning_points_still_warns():
    """1 arcmin at 1.5 kHz on the 3 arcmin dither (tests/test_plant.py::test_fast_vibration_warns_for_paper_rule_only):
    the vibration's rate exceeds the dither's, so the deflection's turning points come from the vibration; the
    plant and both forms of eq. 5 say so."""
    with pytest.warns(HysteresisRegimeWarning) as rec:
        simulate_channel(ChannelConfig(), 0.5, motion=SineMotion(amplitude_rad=ARCMIN, frequency_hz=1500.0))
    who = " ".join(str(w.message) for w in rec)
    assert "correcting filter (unity form)" in who and "correcting filter (paper form)" in who
