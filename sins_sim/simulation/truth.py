"""Mission truth: a vehicle on the Earth carrying a block that moves on its mounts.

The engine needs three things from the truth, at three rates:

* at the plant rate (72 kHz), each gyro's angle ``phi_i(t) = int_0^t omega_ib,i^b`` and its
  rate, to drive the suspension (docs/theory/navigation.md: the gyro senses the body
  rate with respect to inertial space: vehicle rate plus Earth rate plus transport rate, plus
  the block's own vibration);
* at the filter rate, the ideal gyro increments and the accelerometers' velocity increments
  ``int f^b dt`` over each filter sample;
* at the filter rate, the navigation truth: position, NED velocity and attitude ``q_nb``.

Composition. The vehicle frame ``v`` follows the trajectory (``q_nv``, rate ``omega_iv^v``
w.r.t. inertial space, specific force ``f^v``); the block frame ``b`` moves relative to it
by a :class:`~sins_sim.models.motion.Motion3D` (``q_vb``, relative rate ``omega_vb^b``,
closed-form angle ``phi_b``), and optionally translates with a vibration ``a_vib^v``
(vehicle axes, zero-mean velocity, displacement neglected: micrometres). Then

    q_nb = q_nv (x) q_vb,
    omega_ib^b = omega_vb^b + C_bv omega_iv^v,
    f^b = C_bv (f^v + a_vib^v),

so ``phi = phi_b + S`` with ``S(t) = int_0^t C_bv omega_iv^v``.

Accuracy. ``S`` and the velocity increments are integrated per filter sample by 3-point
Gauss-Legendre quadrature with ``C_bv(tau) = (I - [alpha x] + [alpha x]^2 / 2) C_bv(t_{k-1})``,
``alpha = phi_b(tau) - phi_b(t_{k-1})`` the block's rotation within the sample (Bortz 1971
to first order). The neglected terms are of order ``|alpha|^2 |omega_iv|`` (below 1e-11
rad/s for a 1 arcmin, 600 Hz vibration on a vehicle turning at 3 deg/s) and
``|alpha|^2 g`` (below 0.1 ug). The accelerometer's unrotated vibration term uses its
closed-form velocity increment (``Translation.sample_grid``: for the filtered-noise vibration the
difference of its velocity at consecutive sample ends, which are nodes of its interpolant, so that
the increments telescope exactly). Between filter samples ``S`` is the cubic Hermite
interpolant of its node values and rates (``S`` is smooth: its ripple is below 1e-11 rad).
The vehicle is evaluated at ``vehicle_rate_hz`` nodes and interpolated by 4-point
Lagrange polynomials (error of order ``(h_v / T)^4`` for motions with time scale ``T``:
below 1e-12 relative for transitions of 1 s at 200 Hz).

References
----------
.. [1] J. E. Bortz, "A new mathematical formulation for strapdown inertial navigation",
   IEEE Trans. Aerosp. Electron. Syst. AES-7(1), 61-66, 1971.
.. [2] P. G. Savage, "Strapdown inertial navigation integration algorithm design, Part 2:
   Velocity and position algorithms", J. Guid. Control Dyn. 21(2), 208-221, 1998.
.. [3] M. Abramowitz, I. A. Stegun, *Handbook of Mathematical Functions*, 25.4.29
   (Gauss-Legendre nodes and weights) and 25.2.13 (4-point Lagrange interpolation).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sins_sim._kernels import truth as ktruth
from sins_sim.models.motion import AttitudeStream, Motion3D

__all__ = ["MissionTruth", "TruthChunk", "VehicleSampler"]

#: 3-point Gauss-Legendre nodes on [0, 1] ([3] 25.4.29).
GL_NODES = np.array([ktruth.GL_X0, 0.5, ktruth.GL_X2])

#: Fields of a vehicle evaluation that the engine interpolates, and their widths.
VEHICLE_FIELDS = (("lat_rad", 1), ("lon_rad", 1), ("h_m", 1), ("v_ned_m_s", 3), ("q_nv", 4),
                  ("omega_iv_v_rad_s", 3), ("f_v_m_s2", 3))
_COLS = {}
_c = 0
for _name, _w in VEHICLE_FIELDS:
    _COLS[_name] = slice(_c, _c + _w)
    _c += _w
N_VEHICLE_COLS = _c


_LON = _COLS["lon_rad"].start


def _continuous_lon(lon, prev=None):
    """Longitudes without the 2 pi jumps of the antimeridian (continuous from ``prev``), so that the Lagrange
    interpolation between nodes never spans a jump (it gave the truth a longitude across the globe for the
    rows between two nodes astride 180 deg). Values are changed only where a jump is removed."""
    lon = np.array(lon, dtype=np.float64)
    ref = np.concatenate(([prev], lon[:-1])) if prev is not None else np.concatenate(([lon[0]], lon[:-1]))
    step = lon - ref
    turns = np.cumsum(np.where(step > np.pi, -1.0, np.where(step < -np.pi, 1.0, 0.0)))
    if prev is not None and not np.any(turns) and abs(lon[0] - prev) <= np.pi:
        return lon
    return np.where(turns != 0.0, lon + 2.0 * np.pi * turns, lon)


def _wrap_lon(lon) -> None:
    """Interpolated longitudes back into [-pi, pi), in place; exact (untouched) where already inside."""
    lon[lon >= np.pi] -= 2.0 * np.pi
    lon[lon < -np.pi] += 2.0 * np.pi


class VehicleSampler:
    """The vehicle's truth at arbitrary increasing times, from nodes at ``rate_hz``.

    Evaluates the trajectory (an object with ``evaluate(t) -> truth`` carrying the fields
    ``lat_rad, lon_rad, h_m, v_ned_m_s, q_nv, omega_iv_v_rad_s, f_v_m_s2``) on the node grid
    ``j / rate_hz`` and interpolates every field with the 4-point Lagrange polynomial through
    nodes ``j - 1 .. j + 2`` ([3] 25.2.13); quaternions are renormalised. The vehicle is
    taken at rest at its start before ``t = 0`` (node -1 repeats node 0). Nodes are kept in a
    sliding window, so memory does not depend on the mission length.
    """

    def __init__(self, vehicle, rate_hz: float = 200.0):
        self.vehicle = vehicle
        self.h = 1.0 / float(rate_hz)
        self._j0 = -1  # index of the first node held
        self._nodes = np.zeros((0, N_VEHICLE_COLS))
        self._next = 0  # next node index to evaluate

    def _extend(self, j_last: int):
        if j_last < self._next:
            return
        js = np.arange(self._next, j_last + 1)
        tr = self.vehicle.evaluate(js * self.h)
        new = np.empty((js.size, N_VEHICLE_COLS))
        for name, w in VEHICLE_FIELDS:
            new[:, _COLS[name]] = np.asarray(getattr(tr, name), dtype=np.float64).reshape(js.size, w)
        if self._next == 0:
            new = np.concatenate((new[:1], new))
        prev = self._nodes[-1, _LON] if self._nodes.shape[0] else None
        new[:, _LON] = _continuous_lon(new[:, _LON], prev)
        self._nodes = np.concatenate((self._nodes, new))
        self._next = j_last + 1

    def sample(self, t, full_every: int = 1, fields=(), upto: str | None = None) -> np.ndarray:
        """Interpolated rows (columns as :data:`VEHICLE_FIELDS`) at increasing times ``t`` (s).

        With ``full_every > 1`` only every ``full_every``-th row (indices ``full_every - 1``,
        ``2 full_every - 1``, ...) has every field; the others have ``fields`` (adjacent in
        :data:`VEHICLE_FIELDS`) and NaN elsewhere. Each field's values are those of a full row.
        With ``upto`` the rows end with that field (the fields before it and itself, the same values).
        """
        t = np.ascontiguousarray(t, dtype=np.float64)
        self._window(t)
        out = np.empty((t.size, N_VEHICLE_COLS if upto is None else _COLS[upto].stop))
        c_lo = min((_COLS[k].start for k in fields), default=0)
        c_hi = max((_COLS[k].stop for k in fields), default=0)
        if c_hi - c_lo != sum(_COLS[k].stop - _COLS[k].start for k in fields):
            raise ValueError(f"truth.fields: must be adjacent in VEHICLE_FIELDS, got {fields!r}")
        if c_hi > out.shape[1]:
            raise ValueError(f"truth.fields: must end by upto={upto!r}, got {fields!r}")
        # the quaternion renormalised where the rows hold it (the kernel does not check the width)
        q_col = _COLS["q_nv"].start if out.shape[1] >= _COLS["q_nv"].stop else -1
        ktruth.lagrange4(self._nodes, self._j0, self.h, t, q_col, out, int(full_every), c_lo, c_hi)
        if out.shape[1] > _LON:
            _wrap_lon(out[:, _LON])
        return out

    def sample_field(self, t, name: str, last: str | None = None, out=None) -> np.ndarray:
        """One field (not ``q_nv``) at increasing times ``t`` (s), ``(len(t), width)``: the values of
        that field in :meth:`sample`'s rows, without the other columns.

        With ``last``, the fields from ``name`` to ``last`` (adjacent in :data:`VEHICLE_FIELDS`, no
        ``q_nv``) side by side; ``out`` (float64, C-contiguous, of that shape) receives them if given.
        """
        t = np.ascontiguousarray(t, dtype=np.float64)
        self._window(t)
        c_lo, c_hi = _COLS[name].start, _COLS[last or name].stop
        if out is None:
            out = np.empty((t.size, c_hi - c_lo))
        ktruth.lagrange4_columns(self._nodes, self._j0, self.h, t, c_lo, out)
        if c_lo <= _LON < c_hi:
            _wrap_lon(out[:, _LON - c_lo])
        return out

    def _window(self, t):
        """Nodes for the times ``t`` evaluated, and those no later call needs dropped."""
        j_first = int(np.floor(t[0] / self.h))
        j_last = int(np.floor(t[-1] / self.h))
        self._extend(j_last + 2)
        drop = (j_first - 1) - self._j0
        if drop > 256:
            self._nodes = self._nodes[drop:]
            self._j0 += drop

    @staticmethod
    def field(rows: np.ndarray, name: str) -> np.ndarray:
        """One field of :meth:`sample`'s rows (1-D for scalars)."""
        a = rows[..., _COLS[name]]
        return a[..., 0] if a.shape[-1] == 1 else a


@dataclass
class TruthChunk:
    """The truth on the filter grid at nodes ``k0 .. k0 + m - 1`` (time ``k / fs``).

    Attributes
    ----------
    k0 : int
    t_s : ndarray (m,)
    q_nb : ndarray (m, 4)
        Block attitude, body to NED.
    lat_rad, lon_rad, h_m : ndarray (m,)
    v_ned_m_s : ndarray (m, 3)
    dtheta_rad : ndarray (m, 3)
        Ideal gyro increments ``phi(t_k) - phi(t_{k-1})`` (rad).
    dv_m_s : ndarray (m, 3)
        Exact velocity increments of specific force over each sample, body axes (m/s).
    phi_rad : ndarray (m, 3)
        The gyro angles ``phi(t_k)`` themselves (rad): the ideal filter's output.
    """

    k0: int
    t_s: np.ndarray
    q_nb: np.ndarray
    lat_rad: np.ndarray
    lon_rad: np.ndarray
    h_m: np.ndarray
    v_ned_m_s: np.ndarray
    dtheta_rad: np.ndarray
    dv_m_s: np.ndarray
    phi_rad: np.ndarray


class MissionTruth:
    """Streams the mission truth chunk by chunk (see the module docstring).

    Parameters
    ----------
    vehicle : object with ``evaluate(t)``
        The vehicle trajectory's streaming evaluator (``sins_sim.models.motion.trajectory``).
    block : Motion3D
        The block's motion relative to the vehicle.
    translation : object with ``accel(t)``, ``velocity(t)``, ``velocity_increment(ta, tb)``, or None
        The block's translational vibration in vehicle axes (``velocity`` zero-mean).
    plant_rate_hz, filter_rate_hz : float
        The filter rate divides the plant rate.
    vehicle_rate_hz : float
        Node rate of the vehicle interpolation.
    substeps : int
        Magnus substeps of the block attitude per filter sample.
    navigation : bool
        Form the navigation truth. False: only the plant-rate gyro inputs (:meth:`advance` returns
        no chunk): the vehicle's rate alone is interpolated, and neither the velocity increments
        nor the attitude, position and velocity truth are computed (the same gyro angles and
        rates, bit for bit).
    keep_chassis : bool
        Keep what :meth:`chassis_angle_rate` needs after each :meth:`advance` (the vehicle's part of the
        gyro angles without ``block``'s motion: a block on isolators whose angular profile enters at the block).

    :meth:`advance` moves the truth forward to filter node ``k1``: it returns the truth at the
    new nodes and the gyro angles and rates at the plant steps up to ``k1 R``.
    """

    def __init__(self, vehicle, block: Motion3D, translation=None, plant_rate_hz: float = 72000.0,
                 filter_rate_hz: float = 7200.0, vehicle_rate_hz: float = 200.0, substeps: int = 2,
                 navigation: bool = True, keep_chassis: bool = False):
        if not isinstance(block, Motion3D):
            raise ValueError(f"truth.block: must be a Motion3D, got {type(block).__name__}")
        self.navigation = bool(navigation)
        self.keep_chassis = bool(keep_chassis)
        self._s_last = None
        self.vehicle = VehicleSampler(vehicle, vehicle_rate_hz)
        self.block = block
        self.translation = translation
        self.fs = float(filter_rate_hz)
        self.fp = float(plant_rate_hz)
        self.r = int(round(self.fp / self.fs))
        self.hf = 1.0 / self.fs
        self._att = AttitudeStream(block, substeps=substeps)
        self._grid_attitude = None  # block attitude from the plant grid (numeric motions) or AttitudeStream
        self._qvb = np.array([1.0, 0.0, 0.0, 0.0])
        self._k = -1  # last node computed
        self._state = np.zeros(18)  # S, dS/dt, phi_b, C_bv (row-major) at the last node
        self._state[9:18] = np.eye(3).reshape(-1)
        # cubic Hermite basis at the plant steps s = r / R, r = 1..R of a filter sample, and its derivative
        s = np.arange(1, self.r + 1) / self.r
        h = self.hf
        self._herm = np.ascontiguousarray(np.stack([2 * s ** 3 - 3 * s ** 2 + 1, (s ** 3 - 2 * s ** 2 + s) * h,
                                                    -2 * s ** 3 + 3 * s ** 2, (s ** 3 - s ** 2) * h], axis=1))
        self._dherm = np.ascontiguousarray(np.stack([(6 * s ** 2 - 6 * s) / h, 3 * s ** 2 - 4 * s + 1,
                                                     (-6 * s ** 2 + 6 * s) / h, 3 * s ** 2 - 2 * s], axis=1))
        # each Gauss-Legendre node sits between plant steps r0 and r0 + 1 of its sample (step 0: the start)
        pos = GL_NODES * self.r
        self._gl_r0 = np.minimum(np.floor(pos), self.r - 1).astype(np.int64)
        u = pos - self._gl_r0
        self._gl_w = np.ascontiguousarray(np.stack([2 * u ** 3 - 3 * u ** 2 + 1, u ** 3 - 2 * u ** 2 + u,
                                                    -2 * u ** 3 + 3 * u ** 2, u ** 3 - u ** 2], axis=1))
        self._om_fv = None  # vehicle rate and specific force at the nodes of a chunk (reused buffer)
        self._blk = np.zeros(6)  # block angle and rate at the last node
        a0, r0_ = self.block.grid_angle_rate(-1, 1, 1.0 / self.fp)
        self._blk[:3], self._blk[3:] = a0[0], r0_[0]

    @property
    def k(self) -> int:
        """Last filter node computed (-1 before the first call)."""
        return self._k

    def advance(self, k1: int, plant: bool = True):
        """Truth at filter nodes ``k + 1 .. k1`` and gyro inputs at plant steps ``k R + 1 .. k1 R``.

        The first call also returns node 0 (the start; its increments are zero). With
        ``plant=False`` the plant-rate gyro inputs are not formed (``angle`` and ``rate`` are None):
        the block's angles are then evaluated at the filter grid and the Gauss-Legendre nodes only.
        Without navigation (the constructor's ``navigation``) ``chunk`` is None.

        Returns
        -------
        chunk : TruthChunk or None
        angle, rate : ndarray (n R, 3)
            Gyro angles ``phi`` (rad) and rates (rad/s) at the ends of the plant steps; stored
            axis-major (Fortran order), so ``angle[:, i]`` is contiguous.
        """
        first = self._k < 0
        k_prev = max(self._k, 0)
        if k1 <= k_prev:
            raise ValueError(f"truth.k1: must be > {k_prev}, got {k1}")
        navigation = self.navigation
        if not (navigation or plant):
            raise ValueError("truth.advance: needs the plant inputs or the navigation truth, got neither")
        ks = np.arange(k_prev + 1, k1 + 1)
        n = ks.size
        t_end = ks * self.hf
        t_start = t_end - self.hf
        grid = np.concatenate((t_start[:, None] + GL_NODES[None, :] * self.hf, t_end[:, None]), axis=1).reshape(-1)
        f = VehicleSampler.field
        if first:
            row0 = self.vehicle.sample(np.zeros(1))
            self._state[3:6] = f(row0, "omega_iv_v_rad_s")[0]
        if navigation:  # the rates and specific force at every node, the rest only at the sample's end
            if self._om_fv is None or self._om_fv.shape[0] != grid.size:  # reused: read by truth_samples only
                self._om_fv = np.empty((grid.size, 6))
            om_fv = self.vehicle.sample_field(grid, "omega_iv_v_rad_s", "f_v_m_s2", self._om_fv).reshape(n, 4, 6)
            om = om_fv[:, :, 0:3]  # strided views (the kernel reads them in place)
            fv = om_fv[:, :, 3:6]
            # position, velocity and attitude at the sample's end (the rates there are the grid's 4th node)
            end = self.vehicle.sample(t_end, upto="q_nv")
            q_nv = f(end, "q_nv")
        else:  # the rates alone
            om = self.vehicle.sample_field(grid, "omega_iv_v_rad_s").reshape(n, 4, 3)
            fv = om
            q_nv = np.zeros((0, 4))
        if self._grid_attitude is None:  # decided once per run
            self._grid_attitude = bool(plant and self.r % 2 == 0 and not self.block.has_closed_form_attitude)
        # the block's own motion on the plant grid (closed forms), then at the Gauss-Legendre nodes by cubic
        # Hermite interpolation between the two plant steps around each node (error ~ (w h_p)^4 / 384 of the
        # block angle: below 1e-9 relative at 1.5 kHz)
        hp = 1.0 / self.fp
        if plant:
            ang_b, rate_b = self.block.grid_angle_rate(k_prev * self.r, n * self.r, hp)
            if self._grid_attitude:  # block attitude from the same grid (Bortz, Simpson): no second evaluation
                q_vb = np.empty((n, 4))
                ktruth.block_attitude_grid(ang_b, rate_b, self._blk, self.r, hp, self._qvb, q_vb)
            phib = np.empty((n, 4, 3))
            ktruth.block_at_nodes(ang_b, rate_b, self._blk, self.r, self._gl_r0, self._gl_w, hp, phib)
        else:
            phib = np.ascontiguousarray(self.block.gyro_angle(grid).reshape(n, 4, 3))
        if not self._grid_attitude:  # closed forms, or the Magnus integration of the motion itself
            q_vb = np.ascontiguousarray(self._att.advance(t_end))
        if self.translation is not None and navigation:  # acceleration at the nodes, increments, end velocities
            acc, dv_vib, v_vib = self.translation.sample_grid(k_prev, n, self.hf, GL_NODES)
        else:
            acc = np.zeros((0, 4, 3))
            dv_vib = np.zeros((0, 3))
            v_vib = None
        dth = np.empty((n, 3))
        dv = np.empty((n if navigation else 0, 3))
        s_nodes = np.empty((n + 1, 3))
        ds_nodes = np.empty((n + 1, 3))
        q_nb = np.empty((n if navigation else 0, 4))
        ktruth.truth_samples(self.hf, om, fv, acc, dv_vib, phib, q_vb, q_nv, self._state, dth, dv, s_nodes,
                             ds_nodes, q_nb, not navigation)
        if self.keep_chassis:
            self._s_last = (s_nodes, ds_nodes)
        # gyro inputs at the plant rate: block angle (closed form) + Hermite interpolant of S
        angle = rate = None
        if plant:  # block angle (closed form) + Hermite interpolant of S, in place
            # axis-major storage: each axis's column of the (n R, 3) views is contiguous (the channel kernels'
            # input, no strided copy per axis and chunk)
            if ang_b.flags.f_contiguous and rate_b.flags.f_contiguous and ang_b.flags.writeable \
                    and rate_b.flags.writeable:
                # the block's grid is already axis-major and ours (a fresh array per call): add S in place; every
                # element is read once before it is written, so the values are those of a separate output
                ang_ax, rate_ax = ang_b.T, rate_b.T
            else:
                ang_ax = np.empty((3, ang_b.shape[0]))
                rate_ax = np.empty((3, ang_b.shape[0]))
            ktruth.hermite_plant_axes(s_nodes, ds_nodes, self._herm, self._dherm, ang_b, rate_b, ang_ax, rate_ax)
            angle, rate = ang_ax.T, rate_ax.T
        if not navigation:
            self._k = k1
            return None, angle, rate
        phi = phib[:, 3] + s_nodes[1:]
        lat, lon, h = f(end, "lat_rad"), f(end, "lon_rad"), f(end, "h_m")
        v_ned = self._v_ned(f(end, "v_ned_m_s"), q_nv, v_vib)
        if first:
            q0 = f(row0, "q_nv")
            lat = np.concatenate((f(row0, "lat_rad"), lat))
            lon = np.concatenate((f(row0, "lon_rad"), lon))
            h = np.concatenate((f(row0, "h_m"), h))
            v0 = None if self.translation is None else self.translation.velocity(np.zeros(1))
            v_ned = np.concatenate((self._v_ned(f(row0, "v_ned_m_s"), q0, v0), v_ned))
            q_nb = np.concatenate((q0, q_nb))
            dth = np.concatenate((np.zeros((1, 3)), dth))
            dv = np.concatenate((np.zeros((1, 3)), dv))
            phi = np.concatenate((np.zeros((1, 3)), phi))
            ks = np.concatenate(([0], ks))
        self._k = k1
        chunk = TruthChunk(k0=int(ks[0]), t_s=ks * self.hf, q_nb=q_nb, lat_rad=lat, lon_rad=lon, h_m=h,
                           v_ned_m_s=v_ned, dtheta_rad=dth, dv_m_s=dv, phi_rad=phi)
        return chunk, angle, rate

    def chassis_angle_rate(self):
        """The gyro angles and rates of the last :meth:`advance` without the block's own motion: the vehicle's
        part ``S`` alone (the same Hermite interpolant, at the same plant steps; needs ``keep_chassis``).

        Returns
        -------
        angle, rate : ndarray (n R, 3)
            As :meth:`advance`'s (axis-major storage).
        """
        if self._s_last is None:
            raise ValueError("truth.chassis_angle_rate: needs keep_chassis and a call of advance")
        s_nodes, ds_nodes = self._s_last
        n = (s_nodes.shape[0] - 1) * self.r
        zero = np.zeros((n, 3))
        ang = np.empty((3, n))
        rate = np.empty((3, n))
        ktruth.hermite_plant_axes(s_nodes, ds_nodes, self._herm, self._dherm, zero, zero, ang, rate)
        return ang.T, rate.T

    def chassis_linear(self, k_a: int, k_b: int):
        """The chassis' linear acceleration over the plant steps of filter nodes ``k_a + 1 .. k_b``, as the block's
        isolators take it (``sins_sim.models.block.CoupledPlant.step``: ``a0 + a1 tau`` over each step).

        ``a0`` is the translational vibration at each step's start and ``a1`` the chord slope to its end (linear
        in time within a plant step: error ``(w h_p)^2 / 8`` of the acceleration, 1e-3 at 2 kHz and 72 kHz). The
        vibration is given in vehicle axes, which are the block's to first order (the block's tilt on its mounts
        is arcsec); the vehicle's own quasi-static specific force is not applied (the isolators' static sag is
        the equilibrium the linear model is taken about).

        Returns
        -------
        lin0, lin1 : ndarray (3, n R)
            m/s^2 and m/s^3, axis-major; zeros when the run has no translational vibration.
        """
        n = (k_b - k_a) * self.r
        if self.translation is None:
            z = np.zeros((3, n))
            return z, z
        t = (k_a * self.r + np.arange(n + 1)) / self.fp
        acc = np.asarray(self.translation.accel(t), dtype=np.float64)
        lin0 = np.ascontiguousarray(acc[:-1].T)
        lin1 = np.ascontiguousarray(np.diff(acc, axis=0).T * self.fp)
        return lin0, lin1

    @staticmethod
    def _v_ned(v, q_nv, v_vib):
        """The vehicle's NED velocity plus the vibration's velocity ``v_vib`` (vehicle axes) rotated by ``q_nv``."""
        if v_vib is None:
            return v
        out = np.empty((q_nv.shape[0], 3))
        ktruth.add_rotated(np.ascontiguousarray(v), np.ascontiguousarray(q_nv), np.ascontiguousarray(v_vib), out)
        return out
