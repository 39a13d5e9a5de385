"""The sensor block as a body on its isolators (docs/user-guide/block.md).

The nominal SINS block is rigid and moves as prescribed; the three suspensions never meet. Here the block is a
rigid body of mass ``m_b`` and inertia ``J_b`` (about its centre of gravity, block axes) on a set of linear
isolators, base-excited by the chassis and loaded by the three gyros' suspension torques.

Equations (docs/user-guide/block.md; Titterton and Weston 2004, ch. 12 for the isolated IMU;
the linear base-excitation form of any structural-dynamics text, e.g. Rao, *Mechanical Vibrations*, ch. 3 and 6)
----------------------------------------------------------------------------------------------------------------
Coordinates ``q = (x, theta)``: the block's translation of its c.g. and its small rotation vector, both
*relative to the chassis* (block axes). The chassis' own motion, however large, is carried by the truth; the
block adds a small relative motion (arcsec, micrometres) on top of it, so the isolators are linear:

- isolator deflection at the elastic centre ``e`` (offset from the c.g., block axes): ``d = x + theta x e =
  x - [e x] theta``; force on the block ``F = -K_t d - C_t d'``, moment about the c.g.
  ``M = e x F - K_r theta - C_r theta'``. With ``T = [[I, -[e x]], [0, I]]`` the 6x6 stiffness and damping at
  the c.g. are ``K = T^T diag(K_t, K_r) T`` and ``C = T^T diag(C_t, C_r) T`` (symmetric; the offset couples
  translation into rocking: :meth:`BlockParams.stiffness_matrix`);
- gyro ``i`` (input axis ``u_i``, inertia ``J_g,i`` about it) receives the suspension torque
  ``T_i = -J_g,i w0_i^2 (delta_i + Nonl + Diss + 2 zeta delta_i' / w0_i + k5 V_i)`` (eq. 2 times the inertia,
  eq. 9, 10, 14) and the block receives ``-T_i u_i``;
- block: ``M q'' + C q' + K q = -M (a_c, alpha_c) + (0, -sum_i T_i u_i)``, with ``M = diag(m_b I, J_b)`` and
  ``(a_c, alpha_c)`` the chassis' linear and angular acceleration at the block's c.g. (base excitation: the
  chassis acceleration moves to the right-hand side in relative coordinates).

``J_b`` is the block's inertia *without* each gyro body's inertia about its own input axis (the gyro bodies'
inertia about the other axes moves with the block; docs/user-guide/block.md). Gyroscopic terms
``w x J w`` are dropped: the relative rates are below 1e-3 rad/s and the products they form are below 1e-9 of the
terms kept (stated again where the truth composes the block's attitude exactly).

Discretisation: the system is linear and time invariant, ``z' = A z + B u`` with ``z = (q, q')``; over a step
``h`` with an input linear in time, ``u(tau) = u0 + u1 tau``, it is advanced exactly
(``z(h) = Phi z(0) + F0 u0 + F1 u1``, and ``+ F2 u2`` for a quadratic term), the matrices from one matrix
exponential of the augmented system (Van Loan 1978, "Computing integrals involving the matrix exponential",
IEEE TAC 23(3)): :meth:`BlockParams.discrete`.

Closed forms used by the tests and the reports: the isolator transmissibility (:func:`transmissibility`), the
two-body counter-rotation (:func:`counter_rotation`), and the dither coning of two rocking axes
(:func:`coning_beat_amplitude`, :func:`coning_drift_rate`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.linalg import expm

#: Size of the block's state ``z = (x, theta, x', theta')``.
STATE_SIZE = 12
#: Inputs of the discrete step: chassis linear acceleration (3), angular acceleration (3), gyro torques (3).
N_INPUTS = 9


def _skew(v) -> np.ndarray:
    """``[v x]``: the matrix of the cross product with ``v``."""
    x, y, z = (float(c) for c in v)
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def _vec3(value, name: str) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0:
        arr = np.full(3, float(arr))
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: must be three finite numbers (x, y, z), got {value!r}")
    return arr


def _positive(arr: np.ndarray, name: str, allow_zero: bool = False) -> None:
    bad = (arr < 0) if allow_zero else (arr <= 0)
    if np.any(bad):
        rule = ">= 0" if allow_zero else "> 0"
        raise ValueError(f"{name}: every value must be {rule}, got {arr.tolist()}")


@dataclass(frozen=True, eq=False)
class BlockParams:
    """A rigid sensor block on linear isolators, carrying three dithered gyros (SI units).

    Parameters
    ----------
    mass_kg : float
        Block mass with everything it carries (kg).
    inertia_kg_m2 : array (3, 3)
        Inertia tensor about the c.g. in block axes, symmetric positive definite, *without* each gyro body's
        inertia about its own input axis (kg m^2). Off-diagonal entries are the products of inertia
        (``J_xy = -int x y dm``, the tensor convention).
    gyro_inertia_kg_m2 : array (3,)
        Inertia of each dithered gyro body about its input axis (kg m^2).
    input_axes : array (3, 3)
        Row ``i``: the unit input axis ``u_i`` of gyro ``i`` in block axes (nominally the identity; a mounting
        misalignment tilts a row by a few mrad). Rows are normalised.
    k_trans_n_per_m, k_rot_n_m_per_rad : array (3,)
        Isolator stiffness at the elastic centre, translational and rotational, per block axis.
    c_trans_n_s_per_m, c_rot_n_m_s_per_rad : array (3,)
        Isolator damping at the elastic centre, per block axis.
    elastic_centre_m : array (3,)
        Position of the isolators' elastic centre relative to the c.g. (m, block axes).
    """

    mass_kg: float
    inertia_kg_m2: np.ndarray
    gyro_inertia_kg_m2: np.ndarray
    input_axes: np.ndarray = field(default_factory=lambda: np.eye(3))
    k_trans_n_per_m: np.ndarray = field(default_factory=lambda: np.zeros(3))
    k_rot_n_m_per_rad: np.ndarray = field(default_factory=lambda: np.zeros(3))
    c_trans_n_s_per_m: np.ndarray = field(default_factory=lambda: np.zeros(3))
    c_rot_n_m_s_per_rad: np.ndarray = field(default_factory=lambda: np.zeros(3))
    elastic_centre_m: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self):
        set_ = object.__setattr__
        m = float(self.mass_kg)
        if not (math.isfinite(m) and m > 0):
            raise ValueError(f"mass_kg: must be a finite number > 0, got {self.mass_kg!r}")
        set_(self, "mass_kg", m)
        j = np.asarray(self.inertia_kg_m2, dtype=float)
        if j.shape == (3,):
            j = np.diag(j)
        if j.shape != (3, 3) or not np.all(np.isfinite(j)):
            raise ValueError(f"inertia_kg_m2: must be a 3x3 tensor (or three principal values), got {self.inertia_kg_m2!r}")
        if not np.allclose(j, j.T, rtol=0.0, atol=1e-12 * np.abs(j).max()):
            raise ValueError("inertia_kg_m2: must be symmetric (J_xy = J_yx, ...)")
        eig = np.linalg.eigvalsh(j)
        if eig[0] <= 0:
            raise ValueError(f"inertia_kg_m2: must be positive definite (principal moments {eig.tolist()})")
        # triangle inequality of principal moments: a rigid body has J1 + J2 >= J3 (Goldstein, ch. 5)
        if eig[0] + eig[1] < eig[2] * (1.0 - 1e-9):
            raise ValueError(f"inertia_kg_m2: the principal moments {eig.tolist()} break J1 + J2 >= J3; no rigid "
                             "body has them")
        set_(self, "inertia_kg_m2", j)
        jg = _vec3(self.gyro_inertia_kg_m2, "gyro_inertia_kg_m2")
        _positive(jg, "gyro_inertia_kg_m2")
        set_(self, "gyro_inertia_kg_m2", jg)
        u = np.asarray(self.input_axes, dtype=float)
        if u.shape != (3, 3) or not np.all(np.isfinite(u)):
            raise ValueError(f"input_axes: must be three unit vectors (3x3), got {self.input_axes!r}")
        norms = np.linalg.norm(u, axis=1)
        if np.any(norms == 0):
            raise ValueError("input_axes: a gyro input axis is the zero vector")
        u = u / norms[:, None]
        if abs(np.linalg.det(u)) < 0.5:
            raise ValueError("input_axes: the three input axes must be close to orthogonal (|det| >= 0.5)")
        set_(self, "input_axes", u)
        for name in ("k_trans_n_per_m", "k_rot_n_m_per_rad", "c_trans_n_s_per_m", "c_rot_n_m_s_per_rad"):
            v = _vec3(getattr(self, name), name)
            _positive(v, name, allow_zero=True)
            set_(self, name, v)
        set_(self, "elastic_centre_m", _vec3(self.elastic_centre_m, "elastic_centre_m"))

    def __eq__(self, other):
        """Equal when every parameter is (arrays compared element by element: a frozen dataclass compares its
        array fields with ``==``, which has no single truth value)."""
        if not isinstance(other, BlockParams):
            return NotImplemented
        from dataclasses import fields

        return all(np.array_equal(getattr(self, f.name), getattr(other, f.name)) for f in fields(self))

    def __hash__(self):
        return hash(tuple(np.asarray(getattr(self, f)).tobytes() for f in ("mass_kg", "inertia_kg_m2",
                                                                          "gyro_inertia_kg_m2", "input_axes")))

    # --- the matrices ------------------------------------------------------------------------------------------
    def mass_matrix(self) -> np.ndarray:
        """``M = diag(m_b I, J_b)`` (6x6)."""
        out = np.zeros((6, 6))
        out[:3, :3] = self.mass_kg * np.eye(3)
        out[3:, 3:] = self.inertia_kg_m2
        return out

    def _at_cg(self, trans, rot) -> np.ndarray:
        t = np.eye(6)
        t[:3, 3:] = -_skew(self.elastic_centre_m)
        return t.T @ np.diag(np.concatenate([trans, rot])) @ t

    def stiffness_matrix(self) -> np.ndarray:
        """``K = T^T diag(K_t, K_r) T`` at the c.g. (6x6, module docstring)."""
        return self._at_cg(self.k_trans_n_per_m, self.k_rot_n_m_per_rad)

    def damping_matrix(self) -> np.ndarray:
        """``C = T^T diag(C_t, C_r) T`` at the c.g. (6x6)."""
        return self._at_cg(self.c_trans_n_s_per_m, self.c_rot_n_m_s_per_rad)

    def torque_matrix(self) -> np.ndarray:
        """Generalised force on the block per unit gyro torque: column ``i`` is ``(0, -u_i)`` (6x3)."""
        out = np.zeros((6, 3))
        out[3:, :] = -self.input_axes.T
        return out

    def state_space(self, moments: bool = False) -> tuple:
        """``(A, B)`` of ``z' = A z + B u``, ``z = (x, theta, x', theta')``, ``u = (a_c, alpha_c, T)``.

        ``moments``: the last three inputs are the moment on the block about its axes x, y, z instead of the gyros'
        torques (``T`` acts as the moment ``-sum_i T_i u_i``)."""
        minv = np.linalg.inv(self.mass_matrix())
        a = np.zeros((STATE_SIZE, STATE_SIZE))
        a[:6, 6:] = np.eye(6)
        a[6:, :6] = -minv @ self.stiffness_matrix()
        a[6:, 6:] = -minv @ self.damping_matrix()
        b = np.zeros((STATE_SIZE, N_INPUTS))
        b[6:, :6] = -np.eye(6)  # base excitation: -M (a_c, alpha_c), divided by M
        b[6:, 6:] = minv[:, 3:] if moments else minv @ self.torque_matrix()
        return a, b

    def discrete(self, h: float, order: int = 3, moments: bool = False) -> tuple:
        """``(Phi, F0, ..., F_order)``: the exact step of length ``h`` for an input ``sum_k u_k tau^k``
        (``moments``: as :meth:`state_space`).

        Van Loan (1978): the exponential of the system augmented by a chain of integrators,
        ``x' = A x + B p_0, p_0' = p_1, ..., p_order' = 0``; started from ``p_k = I`` (the others 0),
        ``p_0 = tau^k / k!``, so the first block row gives ``Phi = e^{A h}`` and
        ``Fk = int_0^h e^{A (h - s)} B s^k ds = k! (its k-th block)``.
        """
        if not (h > 0 and math.isfinite(h)):
            raise ValueError(f"h: must be a finite step > 0 s, got {h!r}")
        a, b = self.state_space(moments)
        n, m = STATE_SIZE, N_INPUTS
        size = n + (order + 1) * m
        big = np.zeros((size, size))
        big[:n, :n] = a
        big[:n, n:n + m] = b
        for k in range(order):
            big[n + k * m:n + (k + 1) * m, n + (k + 1) * m:n + (k + 2) * m] = np.eye(m)
        e = expm(big * h)
        return (e[:n, :n].copy(),) + tuple(math.factorial(k) * e[:n, n + k * m:n + (k + 1) * m]
                                          for k in range(order + 1))

    def isolator_modes(self, omega_rad_s=None) -> list:
        """The block's six modes on its isolators: ``(frequency_hz, damping_ratio)``, sorted.

        The gyro bodies ride on the block: their inertia about their input axes, which :attr:`inertia_kg_m2`
        leaves out, enters the modes (``J_b + sum_i J_g,i u_i u_i^T``). ``omega_rad_s`` None: each gyro locked to
        the block (its suspension infinitely stiff). ``omega_rad_s`` (3,): each gyro on its linear suspension of
        that resonance, the linearised model the coupled plant integrates (:func:`_matrices9`, the block's damping,
        the suspensions undamped: their loss at the block's small relative motion is below the isolators'); its
        nine modes less the three dither modes (the three whose strain energy lies most in the suspensions).
        From the eigenvalues of the first-order system; a free direction (zero stiffness) gives frequency 0.
        """
        if omega_rad_s is None:
            m = self.mass_matrix()
            for i in range(3):
                e = np.concatenate((np.zeros(3), self.input_axes[i]))
                m = m + self.gyro_inertia_kg_m2[i] * np.outer(e, e)
            k, c, n = self.stiffness_matrix(), self.damping_matrix(), 6
        else:
            m, k = _matrices9(self, np.asarray(omega_rad_s, dtype=float))
            c = np.zeros((9, 9))
            c[:6, :6] = self.damping_matrix()
            n = 9
        a = np.zeros((2 * n, 2 * n))
        a[:n, n:] = np.eye(n)
        minv = np.linalg.inv(m)
        a[n:, :n] = -minv @ k
        a[n:, n:] = -minv @ c
        lam, vec = np.linalg.eig(a)
        modes = []
        for v, x in zip(lam, vec.T):
            if v.imag < 0:
                continue
            wn = abs(v)
            share = 0.0
            if n == 9:  # strain energy in the suspensions, as a fraction of the mode's
                q = x[:n]
                total = abs(np.vdot(q, k @ q))
                share = abs(np.vdot(q[6:], k[6:, 6:] @ q[6:])) / total if total > 0 else 0.0
            if v.imag == 0 and wn > 0:  # overdamped or a free direction's pair (0, -c/m): one per real root pair
                modes.append((share, 0.0, 1.0))
                continue
            modes.append((share, wn / (2 * math.pi), max(0.0, -v.real / wn) if wn > 0 else 0.0))
        if n == 9:
            modes = sorted(modes)[:-3]  # the three dither modes hold their strain energy in the suspensions
        modes = sorted((f, z) for _, f, z in modes)
        return modes[-6:] if len(modes) > 6 else modes

    def angular_momentum(self, theta_dot, delta_dot) -> np.ndarray:
        """Angular momentum of block and gyros about the c.g. relative to a non-rotating chassis (kg m^2/s).

        ``L = J_b theta' + sum_i J_g,i (u_i . theta' + delta_i') u_i`` (the gyro bodies' own axis; their other
        axes are in ``J_b``). ``theta_dot``: (3, ...) and ``delta_dot``: (3, ...).
        """
        td = np.asarray(theta_dot, dtype=float)
        dd = np.asarray(delta_dot, dtype=float)
        u = self.input_axes
        spin = self.gyro_inertia_kg_m2[:, None] * (np.tensordot(u, td, axes=(1, 0)).reshape(3, -1) + dd.reshape(3, -1))
        return (self.inertia_kg_m2 @ td.reshape(3, -1) + u.T @ spin).reshape(td.shape)


def _matrices9(block: BlockParams, om) -> tuple:
    """Mass and stiffness of the linearised undamped block + three suspensions, DOF ``(x, theta, delta)``."""
    jg, u = block.gyro_inertia_kg_m2, block.input_axes
    m9 = np.zeros((9, 9))
    k9 = np.zeros((9, 9))
    m9[:6, :6] = block.mass_matrix()
    k9[:6, :6] = block.stiffness_matrix()
    for i in range(3):
        m9[3:6, 3:6] += jg[i] * np.outer(u[i], u[i])
        m9[3:6, 6 + i] = m9[6 + i, 3:6] = jg[i] * u[i]
        m9[6 + i, 6 + i] = jg[i]
        k9[6 + i, 6 + i] = jg[i] * om[i] ** 2
    return m9, k9


def coupled_dither_frequencies(block: BlockParams, omega_rad_s) -> np.ndarray:
    """The three dither modes of the suspensions on the block (Hz): where each gyro's PLL would lock.

    A suspension whose resonance is ``omega_i`` on a rigid fixture resonates higher on a block that yields: its
    relative mode sees the reduced inertia, ``omega_i sqrt(1 + J_g / J_b)`` well above the isolator modes. Here
    exactly, for the linearised undamped system: degrees of freedom ``(x, theta, delta)``, kinetic energy
    ``(1/2) q'^T M q' + sum_i (1/2) J_g,i (u_i . theta' + delta_i')^2``, potential
    ``(1/2) q^T K q + sum_i (1/2) J_g,i omega_i^2 delta_i^2``. Gyro ``i``'s mode is the root near ``omega_i`` of
    its driving-point dynamic stiffness ``1 / [(K - w^2 M)^-1]_{delta_i delta_i}`` (secant iteration on ``w^2``).
    A root search rather than an eigen-decomposition: with a stiff, heavy block (the rigid limit) the block's
    eigenvalues exceed the dithers' by 1e11 and an eigen-solver loses the dithers' to rounding (1e-5 relative),
    while the driving-point stiffness stays accurate to rounding. ``omega_rad_s``: (3,) each suspension's
    resonance at its dither amplitude (the eq. 9 backbone).
    """
    om = np.asarray(omega_rad_s, dtype=float)
    m9, k9 = _matrices9(block, om)
    e = np.zeros(9)
    out = np.empty(3)
    for i in range(3):
        e[:] = 0.0
        e[6 + i] = 1.0

        def z(w2):
            for nudge in (0.0, 1e-12, -1e-12, 1e-10):  # exactly on another gyro's decoupled mode the matrix is
                try:                                  # singular while this gyro's compliance is not
                    return 1.0 / np.linalg.solve(k9 - w2 * (1.0 + nudge) * m9, e)[6 + i]
                except np.linalg.LinAlgError:
                    continue
            raise ValueError("block: the coupled dither modes could not be found (a singular system)")

        a = om[i] ** 2
        ratio = block.gyro_inertia_kg_m2[i] / float(block.input_axes[i] @ block.inertia_kg_m2 @ block.input_axes[i])
        b = a * (1.0 + ratio)
        za, zb = z(a), z(b)
        for _ in range(60):
            if zb == za:
                break
            c = b - zb * (b - a) / (zb - za)
            a, za = b, zb
            b, zb = c, z(c)
            if abs(b - a) <= 1e-15 * abs(b):
                break
        out[i] = math.sqrt(b) / (2 * math.pi)
    return out


def dither_voltage_factor(block: BlockParams, omega_rad_s, q) -> np.ndarray:
    """Drive voltage on the block relative to eq. 17's, per axis, with each drive at its coupled resonance.

    Eq. 17 (``V_m = -a_m / (Q k5)``) holds for a suspension on a rigid fixture. On the block, the drive torque acts
    between gyro and block, and the block's rocking dissipates in the isolator dampers: the loss per cycle grows by
    ``pi c_r w Theta^2`` (about 8 % for the bundled block) and the voltage with it. Computed from the steady state
    of the linearised coupled system at :func:`coupled_dither_frequencies` (the frequency-domain solve of
    ``tests/test_block.py``), the suspension's hysteretic loss at the amplitude as an equivalent viscous damping
    ``zeta = 1 / (2 Q)``: ``factor_i = Q_i / |delta_i / (k5_i V_i)|``.
    """
    om = np.asarray(omega_rad_s, dtype=float)
    q = np.asarray(q, dtype=float)
    f_c = coupled_dither_frequencies(block, om)
    m9, k9 = _matrices9(block, om)
    jg = block.gyro_inertia_kg_m2
    c9 = np.zeros((9, 9))
    c9[:6, :6] = block.damping_matrix()
    for j in range(3):  # the suspension's loss at its amplitude as viscous damping: 2 zeta w0 J_g = J_g w0 / Q
        c9[6 + j, 6 + j] = jg[j] * om[j] / q[j]
    out = np.empty(3)
    for i in range(3):
        w = 2 * math.pi * f_c[i]
        drive = np.zeros(9, complex)
        drive[6 + i] = jg[i] * om[i] ** 2  # unit k5 V: the piezo torque acts on the deflection only
        out[i] = q[i] / abs(np.linalg.solve(k9 - w * w * m9 + 1j * w * c9, drive)[6 + i])
    return out


# --- closed forms --------------------------------------------------------------------------------------------------
def transmissibility(k: float, c: float, inertia: float, f_hz) -> np.ndarray:
    """Absolute transmissibility of a base-excited one-degree-of-freedom isolator (Rao, *Mechanical Vibrations*,
    sec. 3.6): ``|X / Y| = sqrt((k^2 + (c w)^2) / ((k - I w^2)^2 + (c w)^2))``."""
    w = 2 * np.pi * np.asarray(f_hz, dtype=float)
    return np.sqrt((k ** 2 + (c * w) ** 2) / ((k - inertia * w ** 2) ** 2 + (c * w) ** 2))


def counter_rotation(j_g: float, j_b: float, k: float, c: float, f_hz) -> np.ndarray:
    """Block rotation per unit suspension deflection, ``Theta / Delta``, of a gyro on its suspension in a block on a
    rotational isolator (one axis, fixed chassis), complex.

    Block: ``J_b theta'' + c theta' + k theta = -T``; gyro: ``J_g (theta'' + delta'') = T``. Eliminating ``T``:
    ``(k + i c w - (J_b + J_g) w^2) Theta = J_g w^2 Delta``, whatever drives the suspension. Well above the
    isolator mode it tends to ``-J_g / (J_b + J_g)``, about ``-(J_g / J_b) a`` for a dither of amplitude ``a``
    (docs/user-guide/block.md).
    """
    w = 2 * np.pi * np.asarray(f_hz, dtype=float)
    return j_g * w ** 2 / (k + 1j * c * w - (j_b + j_g) * w ** 2)


def block_rotation_per_deflection(block: "BlockParams", axis: int, f_hz: float, omega0_rad_s=None) -> np.ndarray:
    """The block's rotation vector per unit deflection of gyro ``axis`` at ``f_hz`` (complex (3,), block axes):
    :func:`counter_rotation` for the whole block (6 degrees of freedom, products of inertia, an elastic centre off
    the c.g., input axes off the block axes).

    Gyro ``i``'s body turns by ``u_i . theta + delta_i`` about ``u_i``; its reaction on the block is
    ``J_g,i (u_i . theta'' + delta_i'') u_i``. With ``delta_axis`` prescribed at ``w``:
    ``(K + i w C - w^2 (M + sum_i J_i [0; u_i][0; u_i]^T)) q = w^2 J_g,axis [0; u_axis] Delta``
    (docs/user-guide/block.md). ``J_axis = J_g,axis``; each other gyro either moves with the
    block (``J_i = J_g,i``; ``omega0_rad_s`` None) or follows on its undamped linear suspension,
    ``J_i = J_g,i w0_i^2 / (w0_i^2 - w^2)`` (``omega0_rad_s``: (3,)).
    """
    w = 2.0 * math.pi * float(f_hz)
    m = block.mass_matrix().astype(float)
    for i in range(3):
        e = np.concatenate((np.zeros(3), block.input_axes[i]))
        dyn = 1.0
        if omega0_rad_s is not None and i != axis:
            w0 = float(omega0_rad_s[i])
            dyn = w0 * w0 / (w0 * w0 - w * w)
        m = m + block.gyro_inertia_kg_m2[i] * dyn * np.outer(e, e)
    rhs = np.concatenate((np.zeros(3), block.input_axes[axis])) * (w * w * block.gyro_inertia_kg_m2[axis])
    q = np.linalg.solve(block.stiffness_matrix() + 1j * w * block.damping_matrix() - w * w * m, rhs)
    return q[3:]


def free_block_coupling(block: "BlockParams") -> np.ndarray:
    """What each gyro's SINS angle picks up from each gyro's deflection well above the isolator modes (3, 3).

    With the isolators far below the dithers the block rotates freely under the gyros' reactions:
    ``(J_b + sum_k J_g,k u_k u_k^T) theta'' = -sum_j J_g,j u_j delta_j''``
    (docs/user-guide/block.md, with ``M_iso`` = 0), so from rest ``u_i . theta = sum_j C_ij delta_j`` with
    ``C_ij = -J_g,j u_i . (J_b + sum_k J_g,k u_k u_k^T)^-1 u_j``.

    The off-diagonal terms are the recordings' ``axis_coupling`` (``models.effects.AxisCoupling``: gyro ``i``'s block
    angle gains ``C_ij delta_j``): that effect is this model's cross-axis part above the isolator modes. The diagonal
    is each gyro's own counter-rotation (about ``-J_g / J_b``), which ``axis_coupling`` leaves out: a single axis's
    refit takes it as its suspension's (the dither it sees is ``(1 + C_ii) delta``, and its resonance moves by about
    ``sqrt(1 + J_g / J_b)``, :func:`coupled_dither_frequencies`). Reciprocity: ``C_ij / J_g,j = C_ji / J_g,i``.
    """
    u = np.asarray(block.input_axes, dtype=float)
    jg = np.asarray(block.gyro_inertia_kg_m2, dtype=float)
    m_eff = np.asarray(block.inertia_kg_m2, dtype=float) + (u.T * jg) @ u
    return -(u @ np.linalg.solve(m_eff, u.T)) * jg[None, :]


def inertia_for_coupling(coefficients, gyro_inertia_kg_m2, principal_kg_m2) -> np.ndarray:
    """The block inertia tensor whose free-block coupling (:func:`free_block_coupling`, input axes on the block
    axes) has the given cross-axis coefficients: the products of inertia an ``axis_coupling`` implies.

    Parameters
    ----------
    coefficients : array_like (3, 3)
        ``C_ij`` for ``i != j`` (the diagonal is ignored). A rigid block couples reciprocally,
        ``C_ij / J_g,j = C_ji / J_g,i``; the symmetric part of ``-C_ij / J_g,j`` is used, and its departure is
        returned.
    gyro_inertia_kg_m2 : array_like (3,)
    principal_kg_m2 : array_like (3,)
        The block's moments of inertia about x, y, z (kept; the products of inertia are solved for).

    Returns
    -------
    inertia : ndarray (3, 3)
        ``J_b`` with those moments and the products that reproduce the cross terms (exactly, for reciprocal ones).
    asymmetry : float
        ``max |P_ij - P_ji| / max |P_ij|`` of ``P_ij = -C_ij / J_g,j`` (0 for a reciprocal set).

    Raises
    ------
    ValueError
        When no positive-definite block has those cross terms with those moments (a coupling too strong for the
        inertia: ``|C_ij|`` near ``J_g / J_b``).
    """
    c = np.asarray(coefficients, dtype=float)
    jg = np.asarray(gyro_inertia_kg_m2, dtype=float)
    jp = np.asarray(principal_kg_m2, dtype=float)
    p = -c / jg[None, :]
    off = ~np.eye(3, dtype=bool)
    scale = float(np.max(np.abs(p[off]))) if np.any(p[off]) else 1.0
    asym = float(np.max(np.abs(p - p.T)[off]) / scale) if np.any(p[off]) else 0.0
    p = 0.5 * (p + p.T)
    # P = (J_b + J_g)^-1: its diagonal is unknown, J_b's is given; a fixed point on the diagonal of P
    d = 1.0 / (jp + jg)
    for _ in range(200):
        pm = p.copy()
        np.fill_diagonal(pm, d)
        if np.any(np.linalg.eigvalsh(pm) <= 0.0):
            raise ValueError("axis_coupling: no rigid block with these moments of inertia couples the axes this "
                             "strongly (the coupling must stay well below J_g / J_b)")
        m_eff = np.linalg.inv(pm)
        err = np.diag(m_eff) - (jp + jg)
        if np.max(np.abs(err)) < 1e-14 * np.max(jp):
            break
        d = d * np.diag(m_eff) / (jp + jg)
    inertia = m_eff - np.diag(jg)
    inertia = 0.5 * (inertia + inertia.T)
    if np.any(np.linalg.eigvalsh(inertia) <= 0.0):
        raise ValueError("axis_coupling: the block these coefficients imply is not a physical body (its inertia "
                         "tensor is not positive definite)")
    return inertia, asym


def coning_beat_amplitude(a_x: float, a_y: float, w_x: float, w_y: float) -> float:
    """Amplitude of the coning angle about z from rocking ``a_x sin(w_x t)`` about x and ``a_y sin(w_y t + phi)``
    about y (rad, ``w`` in rad/s, ``w_x != w_y``): ``a_x a_y (w_x + w_y) / (4 |w_x - w_y|)``.

    From the body rate of a small rotation vector, ``w_b = theta' - (1/2) theta x theta' + O(theta^3)``
    (Bortz 1971): its z component integrates to a slow term at ``|w_x - w_y|`` of this amplitude plus a fast one
    at ``w_x + w_y`` (docs/user-guide/block.md).
    """
    return a_x * a_y * (w_x + w_y) / (4.0 * abs(w_x - w_y))


def coning_drift_rate(a_x: float, a_y: float, w: float, phi: float) -> float:
    """Steady coning rate about z of rocking at one frequency, ``a_x sin(w t)`` and ``a_y sin(w t + phi)``
    (rad/s): ``(1/2) a_x a_y w sin(phi)`` (sign: the body-rate integral of ``-(1/2)(theta x theta')_z``)."""
    return 0.5 * a_x * a_y * w * math.sin(phi)


def mode_pulling_hz(block: BlockParams, f_hz, i: int, j: int) -> float:
    """Weak-coupling shift of gyro ``i``'s dither mode by gyro ``j``'s (Hz): two passive modes repel.

    Gyros ``i`` and ``j`` on the block, the third held: with ``u_k . theta = sum_l C_kl delta_l`` (the block turned
    by the gyros' reactions, :func:`free_block_coupling` with the isolators as a negative inertia at the mode,
    ``M_eff = M + sum_k J_g,k [0; u_k][0; u_k]^T - K / w^2``, undamped), gyro ``k`` obeys
    ``(1 + C_kk) delta_k'' + C_kl delta_l'' + w_k^2 delta_k = 0``. Writing ``W_k^2 = w_k^2 / (1 + C_kk)`` (the mode
    with the other gyro held), the characteristic equation is ``(W_i^2 - w^2)(W_j^2 - w^2) = kappa^2 w^4`` with
    ``kappa^2 = C_ij C_ji / ((1 + C_ii)(1 + C_jj))``; to first order in ``kappa^2``,
    ``w^2 = W_i^2 + kappa^2 W_i^4 / (W_i^2 - W_j^2)`` (second-order perturbation of two coupled oscillators;
    Landau and Lifshitz, *Mechanics*, sec. 23), so ``delta f_i = kappa^2 f_i^3 / (2 (f_i^2 - f_j^2))``: positive
    for the higher mode, negative for the lower, ``kappa^2 f / (4 |f_i - f_j|)`` for near modes. ``f_hz``: (3,) the
    modes (each drive's frequency on the block: the shift is second order). Valid while the shift stays well below
    ``|f_i - f_j|``; ``C`` is evaluated at ``f_i`` (it varies by ``(f_iso / f)^2`` over the dither band).
    """
    w = 2.0 * math.pi * float(f_hz[i])
    u6 = np.zeros((6, 3))
    u6[3:, :] = block.input_axes.T
    jg = block.gyro_inertia_kg_m2
    m_eff = block.mass_matrix() + (u6 * jg) @ u6.T - block.stiffness_matrix() / (w * w)
    c = -(u6.T @ np.linalg.solve(m_eff, u6)) * jg[None, :]
    kappa2 = c[i, j] * c[j, i] / ((1.0 + c[i, i]) * (1.0 + c[j, j]))
    fi, fj = float(f_hz[i]), float(f_hz[j])
    if fi == fj:
        raise ValueError(f"f_hz: modes {i} and {j} coincide ({fi:g} Hz); the weak-coupling shift needs them apart")
    return kappa2 * fi ** 3 / (2.0 * (fi * fi - fj * fj))


def block_rotation_from_chassis(block: BlockParams, omega_rad_s, q, axis: int, f_hz: float) -> np.ndarray:
    """The block's absolute rotation (complex (3,), block axes) per unit chassis rotation about ``axis`` at ``f_hz``.

    Base excitation of the linearised block with its three suspensions (degrees of freedom ``(x, theta, delta)``,
    relative to the chassis; mass and stiffness of :func:`coupled_dither_frequencies`, the isolators' damping and
    each suspension's loss as ``J_g w0 / Q``): a chassis rotation ``B e^{i w t}`` about ``axis`` moves every degree
    of freedom as ``r = (0, e_axis, 0)`` does, so ``(K - w^2 M + i w C) q = w^2 M r B`` (Rao, *Mechanical
    Vibrations*, sec. 3.6, in matrix form) and the block turns by ``theta + e_axis B``.
    """
    w = 2.0 * math.pi * float(f_hz)
    dyn, m9 = _dynamic_stiffness9(block, omega_rad_s, q, w)
    r = np.zeros(9)
    r[3 + axis] = 1.0
    sol = np.linalg.solve(dyn, w * w * (m9 @ r))
    return sol[3:6] + r[3:6]


def _dynamic_stiffness9(block: BlockParams, omega_rad_s, q, w: float) -> tuple:
    """``(K - w^2 M + i w C, M)`` of the linearised block with its three suspensions (:func:`_matrices9`; the
    isolators' damping and each suspension's loss as ``J_g w0 / Q``)."""
    om = np.asarray(omega_rad_s, dtype=float)
    m9, k9 = _matrices9(block, om)
    c9 = np.zeros((9, 9))
    c9[:6, :6] = block.damping_matrix()
    jg = block.gyro_inertia_kg_m2
    for k in range(3):
        c9[6 + k, 6 + k] = jg[k] * om[k] / float(np.asarray(q, dtype=float)[k])
    return k9 - w * w * m9 + 1j * w * c9, m9


def block_entry_departure(block: BlockParams, omega_rad_s, q, axis: int, f_hz: float) -> np.ndarray:
    """The block's rotation beyond a profile that enters at it (complex (3,), block axes) per unit profile about
    ``axis`` at ``f_hz``: what the engine's block adds to a measured block profile ``p`` (``motion_enters: block``,
    ``sins_sim.simulation.unit.block_base_excitation``).

    The engine takes the block's relative motion ``theta`` about the frame ``p`` and excites its isolators by
    ``-G p`` (``G = J_b^-1 sum_i J_g,i u_i u_i^T``), so that the gyro bodies carried with the block cancel: in the
    linearised 9-degree-of-freedom model of :func:`block_rotation_from_chassis` (the same ``M``, ``K``, ``C``) the
    block rows' inertial forcing ``-J_b (-G p)'' - sum_i J_g,i u_i u_i^T p''`` is zero and only the suspensions'
    rows keep theirs, ``-J_g,i u_i . p''``: ``(K - w^2 M + i w C) q = w^2 (0, 0, J_g,i u_i . e_axis)`` and the block
    departs from ``p`` by ``q_theta``. For one axis (``J_g``, ``J_b``, rocking stiffness ``k``, damping ``c``,
    suspension ``w0``, ``Q``):

    ``theta / p = J_g w^2 H / (k + i c w - (J_b + J_g) w^2 - J_g w^2 H)``, ``H = w^2 / (w0^2 - w^2 + i w w0 / Q)``

    (``H``: the suspension's deflection per unit rotation of its base, the transmissibility of the dither mode;
    Rao, *Mechanical Vibrations*, sec. 3.6). Far below ``w0`` (``H -> (w / w0)^2``) and away from the rocking mode
    ``w_r`` it is the small ``(J_g / J_b) (w / w0)^2 w^2 / (w_r^2 - w^2)``; near ``w0`` ``H`` grows as
    ``1 / (1 - (w / w0)^2)`` and above the rocking mode the ratio tends to ``-J_g H / (J_b + J_g (1 + H))``:
    -7.2 % at 384.3 Hz under the 421 Hz gyro of the bundled isolated block (417.8 Hz for the line, ``J_g / J_b``
    1.3 %, ``H`` 5.5).
    ``omega_rad_s`` (3,): each suspension's resonance for a small line superposed on its dither (see
    :func:`superposed_line_resonance`); ``q`` (3,): each suspension's Q.
    """
    w = 2.0 * math.pi * float(f_hz)
    dyn, _ = _dynamic_stiffness9(block, omega_rad_s, q, w)
    rhs = np.zeros(9, dtype=complex)
    rhs[6:] = w * w * block.gyro_inertia_kg_m2 * block.input_axes[:, axis]
    return np.linalg.solve(dyn, rhs)[3:6]


# --- the coupled plant ---------------------------------------------------------------------------------------------
#: The torques' smooth parts over a plant step are the polynomial of this degree through their values one to
#: ``LAG_ORDER + 1`` steps back (``_kernels.block``: one step back, so the block's step does not wait for the
#: suspensions' step that ends where it starts).
LAG_ORDER = 3


class BlockStep:
    """The block's exact step of length ``h`` arranged for the coupled kernel (``sins_sim._kernels.block``).

    The torques' smooth parts over ``[t_n, t_n + h]`` enter as the cubic through their values at
    ``t_{n-1} .. t_{n-4}``, folded into one input matrix per history value (``tt``: (4, 3, nc)); only the states
    the torques reach are chained (all 12, or the rotation's 6 when
    the isolators do not couple translation and rotation); the chassis inputs ``(a0, P0, a1, P1)`` go through
    ``gch = [F0, F1]`` (their columns) and the held piezo torques through ``f0t``. ``ax`` (3, ``AX_SIZE``): the
    per-axis coefficients of the axis-decoupled kernel when the block's rotation axes and translations move
    independently (exact zeros off each axis: a diagonal inertia with the elastic centre at the c.g.), else (0,
    ``AX_SIZE``); :attr:`axes` says which.
    """

    def __init__(self, block: BlockParams, h: float):
        from sins_sim._kernels import block as kblock

        # one matrix exponential, with the moments about the block's axes as the last inputs; a gyro's torque T_i
        # acts as the moment -T_i u_i, so its input columns are the moments' times -U^T (the step is linear in B)
        phi, *fm = block.discrete(h, order=LAG_ORDER, moments=True)
        to_torque = -block.input_axes.T
        fk = [np.hstack([f[:, :6], f[:, 6:9] @ to_torque]) for f in fm]
        f0, f1 = fk[0], fk[1]
        k, c = block.stiffness_matrix(), block.damping_matrix()
        coupled = bool(np.any(k[:3, 3:] != 0.0) or np.any(c[:3, 3:] != 0.0))
        self.idx = np.arange(12, dtype=np.int64) if coupled else np.array([3, 4, 5, 9, 10, 11], dtype=np.int64)
        self.ridx = np.array([r for r in range(12) if r not in set(self.idx.tolist())], dtype=np.int64)
        self.phi = np.ascontiguousarray(phi)
        self.phit = np.ascontiguousarray(phi[np.ix_(self.idx, self.idx)].T)
        # the torque over [t_n, t_n + h] is the polynomial through its values at t_{n-1} .. t_{n-1-LAG_ORDER}
        # (tau from t_n): coefficients c = L s, so its input is sum_k Fk c_k = sum_m (sum_k Fk L[k, m]) s_m
        nodes = -h * np.arange(1, LAG_ORDER + 2)
        lag = np.linalg.inv(np.vander(nodes, LAG_ORDER + 1, increasing=True))
        folded = [sum(fk[kk][:, 6:9] * lag[kk, mm] for kk in range(LAG_ORDER + 1)) for mm in range(LAG_ORDER + 1)]
        self.tt = np.ascontiguousarray(np.stack([f[self.idx].T for f in folded]))
        self.gch = np.ascontiguousarray(np.hstack([f0[:, :6], f1[:, :6]]))
        self.f0t = np.ascontiguousarray(f0[:, 6:9])
        where = {int(r): i for i, r in enumerate(self.idx)}
        self.pos = np.array([where[r] for r in (3, 4, 5, 9, 10, 11)], dtype=np.int64)
        self.umat = np.ascontiguousarray(block.input_axes)
        self.jg = np.ascontiguousarray(block.gyro_inertia_kg_m2)
        self.ax = _axis_coefficients(phi, fm, lag) if not coupled else np.zeros((0, kblock.AX_SIZE))

    @property
    def axes(self) -> bool:
        """Whether the block's three rotation axes and three translations are independent (``ax`` filled)."""
        return self.ax.shape[0] == 3


def _groups() -> np.ndarray:
    """Group of each state of ``z``: rotation about axis k is group k, translation along axis k group 3 + k."""
    g = np.empty(STATE_SIZE, dtype=np.int64)
    for k in range(3):
        g[k] = g[6 + k] = 3 + k
        g[3 + k] = g[9 + k] = k
    return g


def _axis_coefficients(phi, fm, lag):
    """``BlockStep.ax`` (``_kernels.block``, ``AX_*``) when the discrete step moves each rotation axis and each
    translation on its own, the gyros' torques entering as the moments they exert about the block's axes
    (``-sum_i T_i u_i``): exactly, with the off-axis entries of the matrices exact zeros (a diagonal inertia with
    the elastic centre at the c.g.; the matrix exponential keeps structural zeros). ``(0, AX_SIZE)`` otherwise."""
    from sins_sim._kernels import block as kblock

    f0, f1 = fm[0], fm[1]
    g = _groups()
    col_group = np.concatenate([3 + np.arange(3), np.arange(3)])  # chassis inputs (a_c, alpha_c)
    if np.any(phi[g[:, None] != g[None, :]] != 0.0):
        return np.zeros((0, kblock.AX_SIZE))
    for f in fm:
        if (np.any(f[:, :6][g[:, None] != col_group[None, :]] != 0.0)
                or np.any(f[:, 6:9][g[:, None] != np.arange(3)[None, :]] != 0.0)):
            return np.zeros((0, kblock.AX_SIZE))
    folded = [sum(fm[kk][:, 6:9] * lag[kk, mm] for kk in range(LAG_ORDER + 1)) for mm in range(LAG_ORDER + 1)]
    ax = np.zeros((3, kblock.AX_SIZE))
    for k in range(3):
        a, b, x, xd = 3 + k, 9 + k, k, 6 + k
        ax[k, kblock.AX_PAA:kblock.AX_PBB + 1] = phi[a, a], phi[a, b], phi[b, a], phi[b, b]
        ax[k, kblock.AX_CA0:kblock.AX_CB1 + 1] = f0[a, 3 + k], f0[b, 3 + k], f1[a, 3 + k], f1[b, 3 + k]
        ax[k, kblock.AX_MA:kblock.AX_MB + 1] = fm[0][a, 6 + k], fm[0][b, 6 + k]
        for mm in range(LAG_ORDER + 1):
            ax[k, kblock.AX_HA + 2 * mm] = folded[mm][a, k]
            ax[k, kblock.AX_HB + 2 * mm] = folded[mm][b, k]
        ax[k, kblock.AX_TAA:kblock.AX_TBB + 1] = phi[x, x], phi[x, xd], phi[xd, x], phi[xd, xd]
        ax[k, kblock.AX_LA0:kblock.AX_LB1 + 1] = f0[x, k], f0[xd, k], f1[x, k], f1[xd, k]
    return ax


#: A block is refused when its fastest isolator mode has ``2 pi f h > MAX_MODE_STEP`` at the plant step ``h`` *and*
#: a gyro body is heavier than :data:`MAX_UNRESOLVED_INERTIA_RATIO` of the block about its axis. The gyros' torques
#: enter the block's exact step as a polynomial over one plant step; that partitioned coupling is exact for a
#: light gyro on a stiff mount (the rigid limit, inertia ratio 1e-12, agrees with the uncoupled plant to 1e-12
#: rad at modes of MHz) but not for a heavy one on a mode the step does not resolve. Measured at 72 kHz with a
#: 1e-4 kg m^2 block axis, the paper suspensions at 3 arcmin: the deflection is right (3.42e-4 rad after 0.1 s)
#: for inertia ratios <= 0.3 at 17.4, 30 and 100 kHz, and for ratios 1 to 8.7 up to 14 kHz (2 pi f h = 1.22); at
#: 17.4 kHz (1.52) ratio 1 gives 1.9e-3 rad and ratio 8.7 overflows. The limits keep a margin on both sides:
#: 1.0 (11.5 kHz at 72 kHz) and 0.1. A real block carries gyros of about 1 % of its inertia on isolator modes of
#: 10-500 Hz, far inside.
MAX_MODE_STEP = 1.0
MAX_UNRESOLVED_INERTIA_RATIO = 0.1


def check_block_resolution(block: BlockParams, rate_hz: float) -> None:
    """Refuse a block whose coupling to its gyros the plant step cannot resolve (:data:`MAX_MODE_STEP`,
    :data:`MAX_UNRESOLVED_INERTIA_RATIO`).

    Raises
    ------
    ValueError
        Naming ``isolators``, the mode, the inertia ratio and the plant rate it would need.
    """
    f_max = max((f for f, _ in block.isolator_modes()), default=0.0)
    limit = MAX_MODE_STEP * rate_hz / (2.0 * math.pi)
    about = np.einsum("ij,jk,ik->i", block.input_axes, block.inertia_kg_m2, block.input_axes)
    ratio = float(np.max(block.gyro_inertia_kg_m2 / about))
    if f_max > limit and ratio > MAX_UNRESOLVED_INERTIA_RATIO:
        raise ValueError(f"isolators: the block's fastest isolator mode is {f_max:.4g} Hz, above plant.rate_hz / "
                         f"(2 pi) = {limit:.4g} Hz, with a gyro of {ratio:.3g} of the block's inertia about its axis "
                         f"(above {MAX_UNRESOLVED_INERTIA_RATIO:g}): the coupled plant step cannot resolve it "
                         f"(isolator modes lie at 10-500 Hz in practice); lower the isolator stiffness or raise "
                         f"plant.rate_hz to at least {2.0 * math.pi * f_max / MAX_MODE_STEP:.4g} Hz")


class CoupledPlant:
    """Three suspensions on one block, stepped together (``sins_sim._kernels.block``); chunked == whole, bit for bit.

    Parameters
    ----------
    suspensions : sequence of three SuspensionParams
        The gyros x, y, z (their ``omega0`` and eq. 9/10/14 parameters).
    block : BlockParams
    settings : PlantSettings
        Plant rate and hysteresis rule; the integrator is the exact one (``plant_exact``), which the coupled step
        extends.

    ``step(ang, rate, volts)`` takes the chassis angle and rate about block axes x, y, z at the ends of the steps
    ((3, n) each), the drives held over each step ((3, n), V) and optionally the chassis linear acceleration at the
    block's c.g. at the start of each step and its slope over the step (``lin0``, ``lin1``: (3, n), m/s^2 and
    m/s^3); it returns the deflections ``delta`` (3, n) and the block's state ``z`` (12, n) at the step ends.
    Each gyro's SINS angle is the chassis angle about its block axis plus ``u_i . theta``.
    """

    def __init__(self, suspensions, block: BlockParams, settings=None):
        from sins_sim._kernels import block as kblock
        from sins_sim._kernels import physics as kphys
        from sins_sim._kernels import plant_exact as kexact
        from sins_sim.models.plant import HYSTERESIS_RULES, PlantSettings, check_resolution

        settings = PlantSettings() if settings is None else settings
        if settings.integrator != "exact":
            raise ValueError("plant.integrator: the coupled block runs on the exact integrator only, got "
                             f"{settings.integrator!r}")
        suspensions = tuple(suspensions)
        if len(suspensions) != 3:
            raise ValueError(f"suspensions: need three (x, y, z), got {len(suspensions)}")
        for s in suspensions:
            check_resolution(s, settings.rate_hz)
        check_block_resolution(block, settings.rate_hz)
        self._k, self._kx, self._kp = kblock, kexact, kphys
        self.suspensions, self.block, self.settings = suspensions, block, settings
        self.h = 1.0 / settings.rate_hz
        self._consts = np.empty((3, kexact.N_CONSTS))
        for a, s in enumerate(suspensions):
            w0 = s.omega0
            kexact._constants(self._consts, a, self.h, w0 * w0, s.k1, s.k2, s.k3, s.k4, s.k5, 2.0 * s.zeta / w0,
                              0.25 / s.f0_hz)
        self._rules = np.full(3, HYSTERESIS_RULES[settings.hysteresis], dtype=np.int64)
        self.stepper = BlockStep(block, self.h)
        self._gain = -self.stepper.jg * self._consts[:, kexact.C_W0SQ]
        self.state = np.zeros((3, kexact.STATE_SIZE))
        self.hyst = np.zeros((3, kphys.HYST_SIZE))
        self.stack = np.zeros((3, kphys.STACK_SIZE))
        self.bstate = np.zeros(kblock.B_SIZE)
        self.reset()

    def reset(self, ang0=(0.0, 0.0, 0.0), rate0=(0.0, 0.0, 0.0)) -> None:
        """Back to rest at t = 0, the chassis at the given angles and rates (about block axes)."""
        self.state[:] = 0.0
        self.bstate[:] = 0.0
        self.state[:, self._kx.X_PHI] = np.asarray(ang0, dtype=float)
        self.state[:, self._kx.X_RATE] = np.asarray(rate0, dtype=float)
        for a in range(3):
            self._kp.hyst_reset(self.hyst[a], self.stack[a])

    def step(self, ang, rate, volts, lin0=None, lin1=None):
        ang = np.ascontiguousarray(ang, dtype=float)
        rate = np.ascontiguousarray(rate, dtype=float)
        volts = np.ascontiguousarray(volts, dtype=float)
        n = volts.shape[1]
        if ang.shape != (3, n) or rate.shape != (3, n) or volts.shape != (3, n):
            raise ValueError(f"ang, rate, volts: must all be (3, n), got {ang.shape}, {rate.shape}, {volts.shape}")
        zeros = np.zeros((3, n))
        lin0 = zeros if lin0 is None else np.ascontiguousarray(lin0, dtype=float)
        lin1 = zeros if lin1 is None else np.ascontiguousarray(lin1, dtype=float)
        kx, cs, st = self._kx, self._consts, self.stepper
        q0s, q1s = np.empty((3, n)), np.empty((3, n))
        for a in range(3):
            kx._forcing(ang[a], rate[a], volts[a], self.state[a, kx.X_PHI], self.state[a, kx.X_RATE], cs[a, kx.C_IH],
                        cs[a, kx.C_IH2], cs[a, kx.C_W0SQ], cs[a, kx.C_K5], q0s[a], q1s[a])
        delta, z = np.empty((3, n)), np.empty((n, STATE_SIZE))
        if st.axes:  # the axis-decoupled kernel forms the chassis' and the piezo inputs in its step loop
            gk5 = self._gain * cs[:, kx.C_K5]
            pa, ra = self.state[:, kx.X_PHI].copy(), self.state[:, kx.X_RATE].copy()
            self._k.run_three_block_axes(0, n, q0s, q1s, cs, self._rules, self.state, self.hyst, self.stack,
                                         self._gain, st.umat, st.ax, ang, rate, volts, gk5, pa, ra, self.bstate, delta,
                                         z)
            self._k.propagate_translation_axes(st.ax, lin0, lin1, self.bstate, z)
            if n:
                self.state[:, kx.X_PHI] = ang[:, -1]
                self.state[:, kx.X_RATE] = rate[:, -1]
            return delta, z.T
        cin = np.empty((n, STATE_SIZE))  # step-major (``_kernels.block``)
        self._k.chassis_input(ang, rate, self.state[:, kx.X_PHI].copy(), self.state[:, kx.X_RATE].copy(),
                              cs[0, kx.C_IH], cs[0, kx.C_IH2], lin0, lin1, st.gch, cin)
        cin += (st.f0t @ (self._gain[:, None] * cs[:, kx.C_K5][:, None] * volts)).T  # the held piezo torques
        z0 = self.bstate[:STATE_SIZE].copy()
        self._k.run_three_block(0, n, q0s, q1s, cs, self._rules, self.state, self.hyst, self.stack, self._gain,
                                st.umat, st.phit, st.tt, st.idx, st.pos, cin, self.bstate, delta, z)
        if st.ridx.size:
            self.bstate[:STATE_SIZE] = z0
            self._k.propagate_rest(st.ridx, st.phi, cin, self.bstate, z)
        if n:
            self.state[:, kx.X_PHI] = ang[:, -1]
            self.state[:, kx.X_RATE] = rate[:, -1]
        return delta, z.T
