"""Frequency responses of the increments each filter delivers, and the filter-tuned coning design.

The navigation of filter ``F`` reads, per axis, the body angle through three linear stages
(docs/theory/suspension.md, "Readout" and "The correcting filter"; the channel chain of
:mod:`sins_sim.simulation.channel`)::

    H_F(f) = H_mech(f) * H_fir(f) * F(f)                                                 (R1)

- ``H_mech``: the dither suspension between the body and the ring laser, eq. 3 of the paper with
  hysteretic (structural) damping, a complex stiffness ``1 + j/Q``::

      H_mech = (1 + j/Q) / (1 + j/Q - (f/f0)^2)

  ``Q`` the suspension's quality factor at the dither amplitude (the dither, not the vibration,
  sets the hysteresis loops), ``f0`` the unit's resonance;
- ``H_fir``: the readout's anti-alias FIR at the plant rate, decimated (its taps, DC gain 1);
- ``F``: the filter's own linear response at the filter rate (``frequency_response`` of the
  eliminator, eq. 5's linear part, a plug-in that provides one).

``ideal`` is the true increment (``H = 1``). A common delay does not enter the coning terms
(they depend on ``H_j conj(H_k)``), so the engine's alignment shift is left out.
The nonlinear parts of eq. 5 (hysteresis and the drive-voltage term, which cancel the
suspension's own) are not in (R1): the linear responses are a model of what the navigation
sees, and :func:`measured_response` measures the real one from a run.

:func:`tuned_design` chooses the filter-tuned coning coefficients
(:func:`sins_sim.navigation.coning.tuned_coefficients`, Mark & Tazartes 2001) for the responses
of one filter over a band.

References
----------
.. [1] W. Mark, D. Tazartes, "Tuning of coning algorithms to gyro data frequency response
   characteristics", J. Guidance, Control, and Dynamics 24(4), 641-647, 2001.
"""

from __future__ import annotations

import math

import numpy as np

from sins_sim.filters import registry as filter_registry
from sins_sim.navigation.coning import coefficient_matrix, flat_coefficients, tuned_coefficients, tuned_residual

__all__ = ["mechanical_response", "fir_response", "increment_responses", "tuned_design", "measured_response",
           "line_amplitudes", "N_BAND_POINTS", "N_WHOLE_POINTS", "whole_band"]

#: Band frequencies of the least-squares design (uniform in Hz).
N_BAND_POINTS = 201
#: Frequencies of the whole-band check of a tuned design (:func:`tuned_design`): a step of 5 Hz at 7.2 kHz, finer
#: than any filter's response varies outside its notches.
N_WHOLE_POINTS = 719
#: The filters whose response is known without a plug-in's ``frequency_response``.
_BUILTIN = ("ideal", "raw", "eliminator", "correcting", "correcting_paper")


def mechanical_response(f_hz, f0_hz: float, q: float) -> np.ndarray:
    """Kinematic response ``phi_sins -> phi_rlg`` of eq. 3 with hysteretic (structural) damping.

    Eq. 10 for a sinusoid is ``(1/Q) * delta`` shifted by 90 degrees, i.e. a complex stiffness
    ``1 + j/Q``: ``H = (1 + j/Q) / (1 + j/Q - (f/f0)^2)``.

    Parameters
    ----------
    f_hz : array_like
        Frequencies (Hz).
    f0_hz : float
        Resonance (Hz).
    q : float
        Quality factor at the dither amplitude.

    Returns
    -------
    ndarray of complex
    """
    r2 = (np.asarray(f_hz, dtype=np.float64) / f0_hz) ** 2
    k = 1.0 + 1j / q
    return k / (k - r2)


def fir_response(readout, f_hz) -> np.ndarray:
    """Gain of the readout's anti-alias FIR at its input rate (complex, its delay removed).

    Parameters
    ----------
    readout : ReadoutParams
    f_hz : array_like
        Frequencies (Hz).

    Returns
    -------
    ndarray of complex, shape (n,)
    """
    taps = readout.taps()
    f = np.atleast_1d(np.asarray(f_hz, dtype=np.float64))
    k = np.arange(taps.size) - 0.5 * (taps.size - 1)
    return (taps[None, :] * np.exp(-2j * math.pi * f[:, None] * k[None, :] / readout.input_rate_hz)).sum(axis=1)


def _filter_response(ch, name: str, axis: str, f_hz) -> np.ndarray:
    if name == "raw":
        return np.ones(np.size(f_hz), dtype=np.complex128)
    if name == "eliminator":
        return ch.eliminator_design().frequency_response(f_hz)
    if name in ("correcting", "correcting_paper"):
        return ch.correcting_design("unity" if name == "correcting" else "paper").frequency_response(f_hz)
    flt = filter_registry.build(name, ch.filter_context(axis))
    fn = getattr(flt, "frequency_response", None) or getattr(getattr(flt, "design", None), "frequency_response", None)
    if fn is None:
        raise ValueError(f"filter {name!r} provides no frequency_response: the filter-tuned coning needs one")
    return np.asarray(fn(f_hz), dtype=np.complex128)


def increment_responses(channels, name: str, f_hz) -> np.ndarray:
    """Per-axis response (R1) of the increments filter ``name`` delivers (complex, shape (3, n)).

    Parameters
    ----------
    channels : sequence of ChannelConfig
        The unit's three channels (x, y, z).
    name : str
        A filter name (built-in or a plug-in with ``frequency_response``).
    f_hz : array_like, shape (n,)
        Frequencies (Hz), below the filter Nyquist.

    Returns
    -------
    ndarray of complex, shape (3, n)

    Raises
    ------
    ValueError
        For a plug-in without a frequency response.
    """
    f = np.atleast_1d(np.asarray(f_hz, dtype=np.float64))
    out = np.ones((3, f.size), dtype=np.complex128)
    if name == "ideal":
        return out
    for i, ch in enumerate(channels):
        s = ch.suspension
        q = s.q_factor(ch.drive.amplitude_rad)
        out[i] = mechanical_response(f, s.f0_hz, q) * fir_response(ch.readout, f) * _filter_response(ch, name, "xyz"[i], f)
    return out


def tuned_design(channels, name: str, band_hz, rate_hz: float) -> dict:
    """Filter-tuned coning coefficients for filter ``name`` over ``band_hz``, what they achieve, and whether they are
    kept or the two-sample algorithm replaces them.

    The least-squares design fits the band only. Where the filter's response is far from a polynomial in the band
    (a notch, a large phase lag, an equaliser), the basis ``sin(l x)`` is nearly collinear at small ``x`` and the
    fit buys a small in-band gain with coefficients in the hundreds, which act on every frequency the increments
    carry: outside the band they leave hundreds of times the coning rate. The design is therefore checked over the
    whole band of the increments (0 to the filter Nyquist, uniform in Hz, :data:`N_WHOLE_POINTS`, every
    frequency weighed the same: a flat vibration spectrum) against the two-sample algorithm, per axis:

    - ``gain`` = two-sample RMS residual minus tuned RMS residual over the design band (what tuning removes);
    - ``loss`` = tuned RMS residual minus two-sample RMS residual over the whole band (what it adds elsewhere).

    The tuned design is kept when ``gain >= loss`` on every axis; otherwise it is *ill-conditioned for this
    filter* and the two-sample coefficients replace it (``fallback`` set, the rejected ``tuned_coefficients``
    kept for the record; docs/theory/navigation.md, "Filter-tuned coning").

    Parameters
    ----------
    channels : sequence of ChannelConfig
    name : str
    band_hz : (float, float)
        Design band (Hz).
    rate_hz : float
        Filter (increment) rate (Hz).

    Returns
    -------
    dict
        ``coefficients`` (ndarray (3, 3), ``[component, lag - 1]``: the ones the navigation uses),
        ``tuned_coefficients`` (the least-squares design), ``flat_coefficients`` (the same design for a flat
        response), ``residual`` (over the band, RMS and maximum of the uncompensated fraction of the coning rate
        per component, :func:`sins_sim.navigation.coning.tuned_residual`, for the tuned and the two-sample
        algorithm), ``whole_band_residual`` (the same over the whole band), ``check`` (per axis ``gain`` and
        ``loss``) and ``fallback`` (None, or ``"two_sample"`` with ``reason``).
    """
    f = np.linspace(band_hz[0], band_hz[1], N_BAND_POINTS)
    h = increment_responses(channels, name, f)
    dc = np.real(increment_responses(channels, name, [0.0])[:, 0])
    coef = tuned_coefficients(h, band_hz, rate_hz, dc_gains=dc, n_points=N_BAND_POINTS)
    whole = whole_band(rate_hz)
    h_whole = increment_responses(channels, name, np.linspace(whole[0], whole[1], N_WHOLE_POINTS))
    res, res_whole = {}, {}
    for label, c in (("filter_tuned", coef), ("two_sample", "two_sample")):
        e = tuned_residual(c, h, band_hz, rate_hz, dc_gains=dc, n_points=N_BAND_POINTS)
        res[label] = {"rms": np.sqrt(np.mean(e * e, axis=1)), "max": np.max(np.abs(e), axis=1)}
        e = tuned_residual(c, h_whole, whole, rate_hz, dc_gains=dc, n_points=N_WHOLE_POINTS)
        res_whole[label] = {"rms": np.sqrt(np.mean(e * e, axis=1)), "max": np.max(np.abs(e), axis=1)}
    gain = res["two_sample"]["rms"] - res["filter_tuned"]["rms"]
    loss = res_whole["filter_tuned"]["rms"] - res_whole["two_sample"]["rms"]
    out = {"coefficients": coef, "tuned_coefficients": coef,
           "flat_coefficients": flat_coefficients(band_hz, rate_hz, N_BAND_POINTS),
           "band_hz": (float(band_hz[0]), float(band_hz[1])), "residual": res, "whole_band_hz": whole,
           "whole_band_residual": res_whole, "check": {"gain": gain, "loss": loss}, "fallback": None}
    bad = np.nonzero(~(gain >= loss))[0]
    if bad.size:
        a = int(bad[np.argmax((loss - gain)[bad])])
        out["coefficients"] = coefficient_matrix("two_sample")
        out["fallback"] = "two_sample"
        out["reason"] = (f"filter_tuned over {band_hz[0]:g}-{band_hz[1]:g} Hz is ill-conditioned for the filter "
                         f"{name} (coefficients up to {np.max(np.abs(coef)):.3g}): about axis {'xyz'[a]} it removes "
                         f"{gain[a]:.3g} of the coning rate in its band but leaves "
                         f"{res_whole['filter_tuned']['rms'][a]:.3g} (two-sample {res_whole['two_sample']['rms'][a]:.3g}) "
                         f"over 0-{0.5 * rate_hz:g} Hz; {name} navigates with two_sample")
    return out


def whole_band(rate_hz: float) -> tuple:
    """The whole band of increments at ``rate_hz`` on which :func:`tuned_design` checks a design (Hz): from one
    grid step above 0 to one grid step below the Nyquist (``tuned_residual`` needs ``0 < low < high < rate/2``)."""
    step = 0.5 * float(rate_hz) / (N_WHOLE_POINTS + 1)
    return (step, 0.5 * float(rate_hz) - step)


def line_amplitudes(t_s, y, freqs_hz, trend: bool = False) -> list:
    """Amplitudes of the sinusoidal lines ``freqs_hz`` in the record ``y`` (least squares on all of them at once,
    with an offset: a multi-frequency lock-in; exact for sinusoids at those frequencies, and lines that are
    resolved over the record, ``|f_i - f_j| T >> 1``, do not leak into each other).

    Parameters
    ----------
    t_s, y : array_like, shape (N,)
    freqs_hz : sequence of float
    trend : bool
        Fit a linear trend with the lines (a drifting record: a ramp over a few periods of a slow line would
        otherwise leak into it).

    Returns
    -------
    list of float
        One amplitude per frequency, in the unit of ``y``.
    """
    t = np.asarray(t_s, dtype=np.float64)
    cols = [np.ones_like(t)] + ([t - t.mean()] if trend else [])
    k = len(cols)
    for f in freqs_hz:
        cols += [np.cos(2 * np.pi * f * t), np.sin(2 * np.pi * f * t)]
    c, *_ = np.linalg.lstsq(np.column_stack(cols), np.asarray(y, dtype=np.float64), rcond=None)
    return [float(math.hypot(c[k + 2 * i], c[k + 1 + 2 * i])) for i in range(len(freqs_hz))]


def measured_response(t_s, error_rad, amplitude_rad, f_hz: float, phase_rad=0.0) -> np.ndarray:
    """Per-axis response at ``f_hz`` measured from a run's gyro-angle error (complex, shape (3,)).

    With the true angle ``A_i sin(2 pi f t + p_i)`` and the error ``e_i = output_i - truth_i``, the
    output is ``H_i`` times the truth, so ``H_i = 1 + E_i / Theta_i`` with ``E_i`` and
    ``Theta_i = A_i exp(j p_i) / (2 j)`` the complex amplitudes of ``exp(j 2 pi f t)``; ``E_i`` is
    the least-squares fit of ``[cos, sin, 1]`` (a lock-in over the record; whole periods make it
    exact for a sinusoid).

    Parameters
    ----------
    t_s : array_like, shape (N,)
        Times of the record (s).
    error_rad : array_like, shape (N, 3)
        Gyro-angle error per axis (rad).
    amplitude_rad : array_like, shape (3,)
        ``A_i`` (rad); axes with ``A_i = 0`` get NaN.
    f_hz : float
        Vibration frequency (Hz).
    phase_rad : array_like, shape (3,)
        ``p_i`` (rad).

    Returns
    -------
    ndarray of complex, shape (3,)
    """
    t = np.asarray(t_s, dtype=np.float64)
    e = np.asarray(error_rad, dtype=np.float64)
    amp = np.broadcast_to(np.asarray(amplitude_rad, dtype=np.float64), (3,))
    ph = np.broadcast_to(np.asarray(phase_rad, dtype=np.float64), (3,))
    w = 2.0 * math.pi * f_hz
    basis = np.stack([np.cos(w * t), np.sin(w * t), np.ones_like(t)], axis=1)
    sol, *_ = np.linalg.lstsq(basis, e, rcond=None)
    # c cos + s sin = Re((c - j s) exp(j w t)): complex amplitude (c - j s) of exp(j w t) in the real signal
    e_c = sol[0] - 1j * sol[1]
    theta = amp * np.exp(1j * (ph - 0.5 * math.pi))  # A sin(w t + p) = Re(A exp(j (p - pi/2)) exp(j w t))
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(amp > 0.0, 1.0 + e_c / theta, np.nan + 0j)
