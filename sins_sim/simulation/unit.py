"""The sensor unit: one sensor block carrying three dithered gyro channels (docs/user-guide/block.md and
"The block as a body").

The rooms read as the machine is built:

- **the block** (:class:`SensorUnit`): rigid, its motion prescribed (the nominal model), or a body on its
  isolators (:class:`~sins_sim.models.block.BlockParams`: mass, inertia, the isolators and their elastic centre,
  each gyro's body and input axis);
- **three channels** on it (:class:`~sins_sim.simulation.channel.ChannelChain`): each with its electronics, drive,
  readout and filters, around its suspension;
- **the mechanics** of a chunk (:class:`SideBySide`): the three suspensions stepped side by side, and with a block
  the block stepped with them in one kernel (``sins_sim._kernels.block``: the dither reactions load the block, the
  block's rotation about each input axis drives that gyro; the coupling);
- **the truth out of the mechanics**: the block's own motion amends the mission truth (:func:`apply_block_to_truth`:
  its attitude, its gyros' ideal increments, its accelerometers' velocity increments, its velocity and position;
  with ``motion_enters: block`` about the frame of the block's own profile, :func:`block_base_excitation`), and
  the unit keeps the block's record for the run's spectrum (:meth:`SensorUnit.keep`).

:func:`sins_sim.simulation.sins.simulate_sins` drives a unit with the mission truth and navigates what it outputs.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from sins_sim._kernels import block as kblock
from sins_sim._kernels import chain as kchain
from sins_sim._kernels import correcting as kcor
from sins_sim._kernels import plant_exact as kexact
from sins_sim._kernels import sos as ksos
from sins_sim.earth import radii
from sins_sim.models.block import BlockStep, coupled_dither_frequencies
from sins_sim.navigation.attitude import dcm_from_quat, quat_from_rotvec, quat_multiply
from sins_sim.simulation.channel import CORRECTING_FORMS, ChannelChain

__all__ = ["SensorUnit", "SideBySide", "side_by_side", "drives_on_block", "run_channels", "apply_block_to_truth", "block_record",
           "block_base_excitation", "gyro_load_matrix", "BLOCK_KEYS", "AXES"]

AXES = ("x", "y", "z")


class SensorUnit:
    """The block and its three channels, built from an IMU (module docstring).

    Parameters
    ----------
    imu : ImuConfig
        The unit (:class:`~sins_sim.simulation.sins.ImuConfig`); ``imu.block`` None is the rigid block.
    seed : int
        Independent random streams per axis: readout noise ``[seed, axis]``, amplitude modulation
        ``[seed, axis, 1]``.
    plugins : tuple of str
        Single-axis plug-in filters each channel runs.
    deflection : bool
        Keep each channel's plant-rate deflection (the pickoffs of the three-axis plug-ins read it).

    Attributes
    ----------
    chains : list of ChannelChain
        x, y, z; with a block each drive runs at its suspension's resonance on the block (:func:`drives_on_block`).
    block : BlockParams or None
    """

    def __init__(self, imu, seed: int, plugins=(), deflection: bool = False):
        self.block = imu.block
        channels = run_channels(imu)
        #: each suspension's resonance at its dither amplitude on a rigid fixture (rad/s): the linearised coupled
        #: model of the reported isolator modes (:func:`block_record`) and of the drives (:func:`drives_on_block`)
        self._omega = [2.0 * math.pi * c.drive_signal().frequency_hz for c in imu.channels]
        self.chains = [ChannelChain(c, imu.drive_control, np.random.default_rng([seed, i]),
                                    np.random.default_rng([seed, i, 1]), plugins=plugins, axis=AXES[i],
                                    effects=imu.effects, deflection=deflection)
                       for i, c in enumerate(channels)]
        self._phi = np.zeros(3)  # the block's added gyro angles, carried between chunks (apply_block_to_truth)
        self._rows = []  # the block's rotation over the kept window, chunk by chunk

    def mechanics(self, side_by_side_wanted: bool):
        """The chunk stepper: with a block, :class:`SideBySide` with the block (always: the block couples the three
        channels; their temperature, PLL and online-estimator schedules run piece by piece inside it); without,
        :class:`SideBySide` when ``side_by_side_wanted`` and the chains allow it, else None (each channel steps
        alone)."""
        if self.block is not None:
            return SideBySide(self.chains, block=self.block)
        return SideBySide(self.chains) if side_by_side_wanted and side_by_side(self.chains) else None

    def amend_truth(self, tc, outs) -> None:
        """The block's own motion into the chunk's truth ``tc`` (:func:`apply_block_to_truth`); no-op when rigid."""
        if self.block is not None:
            self._phi = apply_block_to_truth(tc, outs, self._phi)

    def keep(self, outs, k_prev: int, k1: int, window) -> None:
        """Keep the block's rotation at filter nodes ``window[0] <= k < window[1]`` of a chunk's outputs (row ``j``:
        node ``k_prev + 1 + j``, up to ``k1``); no-op when rigid."""
        if self.block is None:
            return
        lo, hi = max(window[0], k_prev + 1), min(window[1], k1 + 1)
        if lo < hi:
            self._rows.append(np.stack([o["block_theta_end"][lo - k_prev - 1:hi - k_prev - 1] for o in outs], axis=1))

    def record(self, k0: int, fs: float) -> dict | None:
        """``SinsResult.block``: what :meth:`keep` kept, from filter node ``k0`` (:func:`block_record`)."""
        return block_record(self.block, self._rows, k0, fs, self._omega)


def run_channels(imu) -> list:
    """The channels as the engine builds them: the IMU's own, or with a block each drive at its suspension's
    resonance on the block (:func:`drives_on_block`). Every filter built on a drive (the eliminator's band, a
    plug-in's ``dither_hz``) and every report of one takes its drive from here."""
    return list(imu.channels) if getattr(imu, "block", None) is None else drives_on_block(imu)


def drives_on_block(imu) -> list:
    """The channels with each drive at its suspension's resonance on the block (where a PLL would hold it).

    On a block that yields, a suspension resonates above its rigid-fixture resonance
    (:func:`~sins_sim.models.block.coupled_dither_frequencies`: about ``sqrt(1 + J_g / J_b)``, 3 Hz at 386 Hz for
    the bundled block). A drive left at the rigid resonance is then off by about 3 half-bandwidths (Q near 190)
    and needs three times the eq. 17 voltage. A channel whose drive frequency the file sets keeps it.
    ``imu``: an :class:`~sins_sim.simulation.sins.ImuConfig` with a ``block``.
    """

    om = [2.0 * math.pi * c.drive_signal().frequency_hz for c in imu.channels]
    f = coupled_dither_frequencies(imu.block, om)
    return [c if c.drive.frequency_hz is not None else
            dataclasses.replace(c, drive=dataclasses.replace(c.drive, frequency_hz=float(fi)))
            for c, fi in zip(imu.channels, f)]



def side_by_side(chains, schedules: bool = False) -> bool:
    """Whether :class:`SideBySide` can run these chains: three, each on the fused path (no effect stages), and
    without a temperature, PLL or online-estimator schedule unless ``schedules`` (the block's stepper runs them
    piece by piece; the rigid unit runs a scheduled channel on its own)."""
    return len(chains) == 3 and all(ch.path == "fused" and ch._fx is None
                                    and (schedules or (ch._thermal is None and ch._online is None)) for ch in chains)


class SideBySide:
    """The three channels of a SINS over each chunk, their suspensions stepped side by side.

    One call of ``_kernels.chain.drive_plant_three`` per chunk (the three suspensions advance
    one step each in turn, so that the processor overlaps their dependency chains), then each
    channel's readout (``readout_fir``), the six correcting filters side by side
    (``_kernels.correcting.correcting_lanes``, for the same reason) and each eliminator. :meth:`run` returns what :meth:`ChannelChain.run_kernel`
    returns for each chain, bit for bit (``tests/test_engine.py``); call
    :meth:`ChannelChain.check_chunk` on each afterwards. The plant-rate work buffers are kept
    from one chunk to the next: a fresh 1.7 MB array per chunk costs its page faults (about
    0.3 ms per simulated second each). Requires :func:`side_by_side`.

    With ``block`` (:class:`~sins_sim.models.block.BlockParams`) the three suspensions hang on one
    block on its isolators (docs/user-guide/block.md): the chunk's plant steps run
    through ``_kernels.block.drive_plant_three_block`` (the same drives, the block and the three
    suspensions stepped together), each readout sees the chassis angle plus the block's own rotation
    about its gyro's axis (``_kernels.block.block_truth``), and each output carries what the block
    adds to the truth at the filter rate (:data:`BLOCK_KEYS`; :func:`apply_block_to_truth` in the engine).
    """

    def __init__(self, chains, block=None):
        if not side_by_side(chains, schedules=block is not None):
            raise ValueError("channel.side_by_side: needs three chains on the fused path (no effect stages), "
                             "without a temperature, PLL or online schedule unless on a block")
        self.chains = list(chains)
        self._n = -1
        self.block = block
        if block is not None:
            self._thermal = [ch.thermal for ch in chains]
            self._online = [ch.online for ch in chains]
            self._model = next((th.model for th in self._thermal if th is not None and th.model is not None), None)
            self._step_temp = None  # the temperature the block's step was built at (None: the file's block)
            self._step = BlockStep(block, chains[0].plant.h)
            self._gain = np.array([-self._step.jg[a] * ch.fpar[kchain.P_W0SQ] for a, ch in enumerate(chains)])
            self.bstate = np.zeros(kblock.B_SIZE)
            self.tcarry = np.zeros(kblock.T_SIZE)
            # the base frame's angle and rate at the chunk's start: the suspensions' last SINS angle when every
            # profile enters at the chassis (so the rigid and chassis-entry runs keep today's numbers)
            self.base_prev = np.concatenate([[p.state[kexact.X_PHI] for p in (ch.plant for ch in chains)],
                                             [p.state[kexact.X_RATE] for p in (ch.plant for ch in chains)]])
            self._gload = gyro_load_matrix(block)

    def _work(self, n: int):
        if n != self._n:
            self._buf = np.empty((4, 3, n))  # deflection, drive, and the plant's forcing q0, q1
            self._n = n
        return self._buf

    def _block_work(self, n: int):
        """The block's plant-rate work buffers, kept while the chunk length stays: its state and inputs (step-major),
        a zero chassis linear acceleration (for a run without one) and each gyro's added angle."""
        if getattr(self, "_bn", -1) != n:
            self._bbuf = (np.empty((n, 12)), np.empty((n, 12)), np.zeros((3, n)), np.empty((3, n)))
            self._bn = n
        return self._bbuf

    def run(self, i0: int, angle: np.ndarray, rate: np.ndarray, lin=None, base=None) -> list:
        """Advance the three chains over a chunk; ``angle, rate``: (n, 3) at the ends of the plant steps.

        ``lin``: with a block, the chassis' linear acceleration that drives the isolators, ``(lin0, lin1)``
        ((3, n) each: at each step's start and its slope over the step, m/s^2 and m/s^3;
        ``simulation.truth.MissionTruth.chassis_linear``); None: none.

        ``base``: with a block whose angular profile enters at the block, the chassis' angle and rate without
        that profile, ``(angle_c, rate_c)`` ((n, 3) each, ``MissionTruth.chassis_angle_rate``); None: every
        profile enters at the chassis. The block's relative motion is then taken about the profile's frame
        (:func:`block_base_excitation`).

        Each output's ``delta`` is a view of a work buffer, valid until the next call (as on the
        per-channel fused path).

        With a block and a channel's temperature, PLL or online-estimator schedule the chunk runs in pieces that
        end at the schedules' blocks and updates (counted from step 0, so results do not depend on chunking), as
        a channel alone runs them (``ChannelChain._in_blocks``, ``OnlineLoop.run``): before each piece every
        schedule loads its block (:meth:`_enter`), after it every estimator takes the piece's readout and drive.
        """
        if self.block is None or not any(self._thermal + self._online):
            return self._run_piece(i0, angle, rate, lin, base)
        r_dec = self.chains[0].r_dec
        if i0 % r_dec:
            raise ValueError(f"channel.chunk: with a temperature profile, PLL tracking or an online estimator a "
                             f"chunk must start at a multiple of the decimation {r_dec}, got step {i0}")
        n = angle.shape[0]
        pieces = []
        j = 0
        while j < n:
            g = i0 + j
            ends = [(g // th.block + 1) * th.block for th in self._thermal if th is not None]
            ends += [on.next_update(g) for on in self._online if on is not None]
            j1 = min(n, min(ends) - i0)
            self._enter(g)
            piece_lin = None if lin is None else tuple(np.ascontiguousarray(x[:, j:j1]) for x in lin)
            piece_base = None if base is None else tuple(x[j:j1] for x in base)
            outs = self._run_piece(g, angle[j:j1], rate[j:j1], piece_lin, piece_base)
            for ch, on, out in zip(self.chains, self._online, outs):
                out["delta"] = np.array(out["delta"])  # a view of the work buffer the next piece reuses
                if on is not None:
                    on.after_piece(ch, out, i0 + j1)
            pieces.append(outs)
            j = j1
        if len(pieces) == 1:
            return pieces[0]
        return [{k: np.concatenate([p[a][k] for p in pieces]) for k in pieces[0][a]} for a in range(3)]

    def _enter(self, g: int) -> None:
        """Load, for the piece that starts at plant step ``g``, each channel's temperature block: its suspension
        (and the dither reaction's gain ``-J_g omega0^2`` on the block), its drive, which a tracking PLL locks to
        the coupled dither mode of the three suspensions on the block at that temperature
        (:func:`~sins_sim.models.block.coupled_dither_frequencies`), and the block's isolators at that
        temperature (:meth:`~sins_sim.simulation.temperature.ThermalModel.block_at`)."""
        if all(th is None or th.loaded == g // th.block for th in self._thermal):
            return
        plans = [None if th is None else th.plan(g // th.block) for th in self._thermal]
        block = self.block
        if self._model is not None and self._model.moves_isolators:
            temp = next(p[1] for p in plans if p is not None)
            if temp != self._step_temp:
                self._block_now = self._model.block_at(self.block, temp)
                self._step = BlockStep(self._block_now, self.chains[0].plant.h)
                self._step_temp = temp
            block = self._block_now
        drives = [None] * 3
        if any(p is not None and p[3] is not None for p in plans):  # a tracking PLL: the coupled modes
            f_lock = [p[3] if p is not None and p[3] is not None else ch.drive_hz for p, ch in zip(plans, self.chains)]
            drives = coupled_dither_frequencies(block, 2.0 * math.pi * np.asarray(f_lock))
        for a, (ch, th) in enumerate(zip(self.chains, self._thermal)):
            if th is not None:
                th.enter(ch, g // th.block, drive_hz=drives[a] if th.track else None)
                self._gain[a] = -self._step.jg[a] * ch.fpar[kchain.P_W0SQ]

    def _run_piece(self, i0: int, angle: np.ndarray, rate: np.ndarray, lin=None, base=None) -> list:
        """:meth:`run` over a piece within one parameter block of every schedule."""
        chains = self.chains
        n = angle.shape[0]
        draws = [ch._kernel_draws(i0, n) for ch in chains]
        uniforms = np.zeros((3, max(1, max(u.size for _, u in draws))))
        for a, (_, u) in enumerate(draws):
            uniforms[a, :u.size] = u
        plants = [ch.plant for ch in chains]
        dstate = np.stack([ch.dstate for ch in chains])
        pstate = np.stack([p.state for p in plants])
        physt = np.stack([p.hyst for p in plants])
        pstack = np.stack([p.stack for p in plants])
        angle_ax = np.ascontiguousarray(angle.T)  # axis-major input: a view, no copy
        delta, volts, q0s, q1s = self._work(n)
        used = np.zeros(3, dtype=np.int64)
        m = n // chains[0].r_dec
        fpar = np.stack([ch.fpar for ch in chains])
        ipar = np.stack([ch.ipar for ch in chains])
        if self.block is None:
            kchain.drive_plant_three(i0, angle_ax, np.ascontiguousarray(rate.T), uniforms, fpar, ipar,
                                     dstate, pstate, physt, pstack, delta, volts, q0s, q1s, used)
            seen = angle_ax
        else:
            rate_ax = np.ascontiguousarray(rate.T)
            z, cin, zero, add = self._block_work(n)
            lin0, lin1 = (zero, zero) if lin is None else lin
            if base is None:
                bang, brate = angle_ax, rate_ax
            else:
                bang, brate = block_base_excitation(angle_ax, rate_ax, base[0].T, base[1].T, self._gload)
            st = self._step
            kblock.drive_plant_three_block(i0, angle_ax, rate_ax, uniforms, fpar, ipar, dstate, pstate, physt, pstack,
                                           delta, volts, q0s, q1s, used, self._gain, st.umat, st.phi, st.phit, st.tt,
                                           st.f0t, st.gch, st.idx, st.ridx, st.pos, st.ax, lin0, lin1, self.bstate,
                                           cin, z, bang, brate, self.base_prev)
            extra = np.empty((len(BLOCK_KEYS), 3, m))  # BLOCK_KEYS, in order
            kblock.block_truth(z, rate_ax, lin0, lin1, st.umat, chains[0].plant.h, chains[0].r_dec, self.tcarry, add,
                               *extra)
            seen = angle_ax + add  # each gyro: the chassis angle plus the block's own rotation about its axis
        x = np.empty((2, 3, m))  # readout angle and drive at the filter rate, per axis
        for a, ch in enumerate(chains):
            ch.dstate[:] = dstate[a]
            plants[a].state[:] = pstate[a]
            plants[a].hyst[:] = physt[a]
            plants[a].stack[:] = pstack[a]
            kchain.readout_fir(seen[a], draws[a][0], ch.fpar, ch.ipar, ch.dstate, ch.taps,
                               ch.readout.decimator._hist, ch.vdec._hist, delta[a], volts[a], ch._buffers(n)[2],
                               x[0, a], x[1, a])
        # the six correcting filters (two forms per axis, rows of cpar) side by side, their state read from
        # and written back to the filter objects; then each eliminator
        eq5 = [ch.filters[name] for ch in chains for name in CORRECTING_FORMS]
        cpar = np.concatenate([ch.cpar for ch in chains])
        fstate = np.stack([f.state for f in eq5])
        fhyst = np.stack([f.hyst for f in eq5])
        fstack = np.stack([f.stack for f in eq5])
        y = np.empty((6, m))
        kcor.correcting_lanes(x[0], x[1], _LANE_ROWS, np.ascontiguousarray(cpar[:, :kchain.C_RULE]),
                              cpar[:, kchain.C_RULE].astype(np.int64), fstate, fhyst, fstack, y)
        for f, st, hy, sk in zip(eq5, fstate, fhyst, fstack):
            f.state[:] = st
            f.hyst[:] = hy
            f.stack[:] = sk
        outs = []
        for a, ch in enumerate(chains):
            el = ch.filters["eliminator"]
            out = {"raw": x[0, a], "volts": x[1, a], "correcting": y[2 * a], "correcting_paper": y[2 * a + 1],
                   "eliminator": np.empty(m)}
            ksos.sos_filter(el._sos, out["raw"], el._zi, out["eliminator"])
            ch._run_plugins(out)
            ch._keep_deflection(out, delta[a])
            if self.block is not None:
                for key, row in zip(BLOCK_KEYS, extra):
                    out[key] = row[a]
            outs.append(out)
        return outs


#: What :meth:`SideBySide.run` adds to each axis's output with a block (filter rate, see ``_kernels.block.block_truth``).
BLOCK_KEYS = ("block_dth", "block_theta_avg", "block_theta_end", "block_dvel", "block_xdot_end", "block_x_end")


def apply_block_to_truth(tc, outs, block_phi):
    """The truth as the block's sensors see it: the chunk ``tc`` (``simulation.truth.TruthChunk``) amended in place
    by the block's relative motion that :class:`SideBySide` returned with ``outs``.

    - ideal gyro increments and angles: ``+ u_i . Delta(theta + c)`` (``_kernels.block.block_truth``); the running
      sum ``block_phi`` (3,) is carried between chunks and returned;
    - attitude: ``q_nb (x) exp(theta)`` (the block rotated by ``theta`` relative to the chassis);
    - velocity increments, in the rocked block's axes: ``dv - theta_avg x dv + (1/2) theta_avg x (theta_avg x dv)``
      (the rotation matrix of the rotation vector ``-theta`` to second order, Groves 2013, sec. 2.2.4: the second
      order rectifies 100 arcsec of rocking against gravity into 1e-6 m/s^2) plus what its relative motion adds
      (``_kernels.block.block_truth``): ``int (I - [theta x]) x'' dt`` (sculling included), the chassis' rotation
      carrying the block's translation, ``2 w x x' + w' x x + w x (w x x)`` (Groves 2013, sec. 2.3: motion with
      respect to a rotating frame), and the tilt's variation within the sample against the chassis' linear
      vibration;
    - velocity: the chassis' plus the block's c.g. velocity relative to the chassis point, ``x' + w x x`` (chassis
      axes, rotated by the chassis' attitude: cm/s under chassis vibration near the isolator modes);
    - position: the chassis' plus the block's relative c.g. displacement ``x`` (block axes, rotated to NED by the
      chassis' attitude: ``d_ned = C_nb,chassis x``), as latitude ``+ d_N / (R_N + h)``, longitude
      ``+ d_E / ((R_E + h) cos lat)`` and height ``- d_D`` (radii of :func:`sins_sim.earth.radii`; Titterton and
      Weston 2004, eq. 3.87-3.89 for the small displacement). Tens of micrometres under chassis vibration near the
      isolator modes. The navigated position is then the block's, the reference trajectory the chassis'; the
      velocity above is its derivative (``C_nc x`` differentiated: ``C_nc (x' + w x x)``).

    The first chunk's truth also holds node 0 (increments zero, the block at rest on its mounts), which the block
    leaves as it is.
    """
    m = outs[0]["block_dth"].shape[0]
    rows = tc.dtheta_rad.shape[0]
    lead = rows - m
    dth = np.stack([o["block_dth"] for o in outs], axis=1)
    tc.dtheta_rad[lead:] += dth
    cum = block_phi + np.cumsum(dth, axis=0)
    tc.phi_rad[lead:] += cum
    theta = np.stack([o["block_theta_end"] for o in outs], axis=1)
    q_chassis = tc.q_nb[lead:].copy()
    tc.q_nb[lead:] = quat_multiply(q_chassis, quat_from_rotvec(theta))
    tavg = np.stack([o["block_theta_avg"] for o in outs], axis=1)
    dvel = np.stack([o["block_dvel"] for o in outs], axis=1)
    dv = tc.dv_m_s[lead:]
    tilt = np.cross(tavg, dv)
    tc.dv_m_s[lead:] = dv - tilt + 0.5 * np.cross(tavg, tilt) + dvel
    xdot = np.stack([o["block_xdot_end"] for o in outs], axis=1)
    c_nb = dcm_from_quat(q_chassis)
    tc.v_ned_m_s[lead:] += np.einsum("nij,nj->ni", c_nb, xdot)
    d_ned = np.einsum("nij,nj->ni", c_nb, np.stack([o["block_x_end"] for o in outs], axis=1))
    lat, h = tc.lat_rad[lead:], tc.h_m[lead:]
    r_n, r_e = radii(lat)
    tc.lat_rad = tc.lat_rad.copy()  # the chunk's position rows may be views of the vehicle sampler's rows
    tc.lon_rad = tc.lon_rad.copy()
    tc.h_m = tc.h_m.copy()
    tc.lat_rad[lead:] += d_ned[:, 0] / (r_n + h)
    tc.lon_rad[lead:] += d_ned[:, 1] / ((r_e + h) * np.cos(lat))
    tc.h_m[lead:] -= d_ned[:, 2]
    return cum[-1] if m else block_phi


def gyro_load_matrix(block) -> np.ndarray:
    """``G = J_b^-1 sum_i J_g,i u_i u_i^T`` (3x3): the gyro bodies' inertia about their input axes relative to the
    block's (:func:`block_base_excitation`); about ``J_g / J_b`` (2 % for the bundled block) on each axis."""
    load = sum(jg * np.outer(u, u) for jg, u in zip(block.gyro_inertia_kg_m2, block.input_axes))
    return np.linalg.solve(block.inertia_kg_m2, load)


def block_base_excitation(angle, rate, angle_c, rate_c, gload):
    """The frame that excites the block through its isolators when the angular profile enters at the block.

    ``angle, rate``: (3, n) the SINS angle and rate with the profile ``p`` (the chassis' ``c`` plus ``p``);
    ``angle_c, rate_c``: (3, n) the chassis' alone; returns ``c - G p`` and its rate (``G``:
    :func:`gyro_load_matrix`).

    Definition. A profile that enters at the block is the block's own rotation as measured on it (as on a rigid
    block): what the block does, the gyros' load and the isolators' forces included, without the dithers. The
    block's linear model (``sins_sim.models.block``) lets the rest be superposed (Meirovitch, *Fundamentals of
    Vibrations*, 2001, sec. 3.1: the response of a linear system to a sum of inputs is the sum of the responses):
    the block's rotation is ``p`` plus its response to what enters at the chassis (the chassis' own rotation
    ``c``, its linear vibration) and to the dither reactions. So the block's relative motion is taken about the
    frame ``c + p`` (the gyros and the truth see ``c + p + theta``), and its isolators are excited by the chassis
    alone. The suspensions, driven by ``c + p + theta``, also react to ``p``: about ``-J_g p''`` on the block
    below their resonance (the gyro bodies carried with it), a load the measured ``p`` already holds. The
    base excitation removes that part: ``-J_b (c - G p)'' = -J_b c'' + sum_i J_g,i u_i u_i^T p''``. What
    remains is the suspensions' dynamic part: each dither mode, base-excited by ``p`` at ``w``, deflects by
    ``H = w^2 / (w0^2 - w^2 + i w w0 / Q)`` of it (its transmissibility) and loads the block by ``J_g w^2 H``. The
    block's rotation then differs from ``p`` plus its response to the rest by
    ``J_g w^2 H / (k + i c w - (J_b + J_g) w^2 - J_g w^2 H)`` of ``p`` (one axis; the whole block:
    :func:`~sins_sim.models.block.block_entry_departure`). Far below ``w0`` that is the small
    ``(J_g / J_b) (w / w0)^2 w^2 / (w_r^2 - w^2)`` (``w_r`` the rocking mode): 1.3e-5 for a 30 Hz profile on 386 Hz
    gyros and a 100 Hz mount (``tests/test_block_motion_entry.py``). Near a gyro's resonance ``H`` grows as
    ``1 / (1 - (w / w0)^2)`` and so does the departure: 7.2 % at 384.3 Hz under the 421 Hz gyro of the bundled
    isolated block (the block turns by 0.93 of the profile; ``tests/test_block_entry_resonance.py``, within 1.3 %).
    A profile measured on a real block near a gyro's resonance already holds that reaction; the engine then counts it
    twice by that much. ``w0`` for a line superposed on the dither is
    :meth:`~sins_sim.models.suspension.SuspensionParams.line_resonance_hz`.
    """
    return angle_c - gload @ (angle - angle_c), rate_c - gload @ (rate - rate_c)


#: Input row of each correcting filter in :meth:`SideBySide.run`: the two forms of axis ``a`` read row ``a``.
_LANE_ROWS = np.array([0, 0, 1, 1, 2, 2], dtype=np.int64)


def block_record(block, rows, k0: int, fs: float, omega_rad_s=None) -> dict | None:
    """:attr:`SinsResult.block` from the kept rows of the block's rotation (filter nodes ``k0 ..``).

    ``isolator_modes_hz``: the modes of the linearised block with its gyros on their suspensions of resonance
    ``omega_rad_s`` (3,; None: the gyros locked to the block), :meth:`~sins_sim.models.block.BlockParams.isolator_modes`:
    the gyros' inertia included, as the coupled plant integrates it."""
    if block is None:
        return None
    theta = np.concatenate(rows) if rows else np.zeros((0, 3))
    modes = [m for m in block.isolator_modes(omega_rad_s) if m[0] > 0.0]
    return {"t_s": (k0 + np.arange(theta.shape[0])) / fs, "theta_rad": theta, "rate_hz": fs,
            "isolator_modes_hz": [float(f) for f, _ in modes], "isolator_damping": [float(z) for _, z in modes]}
