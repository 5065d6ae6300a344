"""Finite rotations: rotation vectors, unit quaternions and rotation matrices.

Conventions (Crisfield 1997, vol. 2, ch. 16; Battini & Pacoste 2002):

* a rotation vector ``theta`` (axis times angle) maps to a rotation matrix by the
  exponential map ``R = exp(S(theta))`` (Rodrigues' formula);
* quaternions are stored ``(q0, q1, q2, q3)`` with scalar part first;
* increments are *spatial* (left) spins: ``R_new = exp(S(dw)) R``;
* ``Ts(theta)`` is the tangent operator with ``delta w = Ts(theta) delta theta``
  for ``delta R = S(delta w) R``; ``Ts_inv`` is its inverse.

Small angles use Taylor series so that every kernel is smooth through zero.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from harnesspipe.fe.loops import loop_kernel

SMALL_ANGLE = 1.0e-4   # below this, sin(a/2)/a and atan ratios use their Taylor series
SERIES_ANGLE = 0.05    # below this, ratios that cancel catastrophically use their series


@njit(cache=True)
def skew(v, out):
    """Write the skew matrix S(v) (S(v) a = v x a) into ``out`` (3x3)."""
    out[0, 0] = 0.0
    out[0, 1] = -v[2]
    out[0, 2] = v[1]
    out[1, 0] = v[2]
    out[1, 1] = 0.0
    out[1, 2] = -v[0]
    out[2, 0] = -v[1]
    out[2, 1] = v[0]
    out[2, 2] = 0.0


@njit(cache=True)
def quat_from_rotvec(theta, q):
    """Unit quaternion of the rotation vector ``theta`` (exponential map) into ``q``."""
    a = np.sqrt(theta[0] ** 2 + theta[1] ** 2 + theta[2] ** 2)
    if a < SMALL_ANGLE:
        s = 0.5 - a * a / 48.0  # sin(a/2)/a
        q[0] = 1.0 - a * a / 8.0
    else:
        s = np.sin(0.5 * a) / a
        q[0] = np.cos(0.5 * a)
    q[1] = s * theta[0]
    q[2] = s * theta[1]
    q[3] = s * theta[2]


@njit(cache=True, inline="always")
def rotvec_from_quat(q, theta):
    """Rotation vector (angle in [0, pi]) of the unit quaternion ``q`` (log map)."""
    q0, q1, q2, q3 = q[0], q[1], q[2], q[3]
    if q0 < 0.0:  # q and -q are the same rotation; take the shorter angle
        q0, q1, q2, q3 = -q0, -q1, -q2, -q3
    vn = np.sqrt(q1 * q1 + q2 * q2 + q3 * q3)
    a = 2.0 * np.arctan2(vn, q0)
    if vn < 0.5 * SMALL_ANGLE:
        f = 2.0 / q0 * (1.0 - vn * vn / (3.0 * q0 * q0))  # 2 atan(v/q0)/v
    else:
        f = a / vn
    theta[0] = f * q1
    theta[1] = f * q2
    theta[2] = f * q3


@njit(cache=True)
def quat_mul(p, q, out):
    """Quaternion product ``out = p * q`` (rotation q first, then p)."""
    o0 = p[0] * q[0] - p[1] * q[1] - p[2] * q[2] - p[3] * q[3]
    o1 = p[0] * q[1] + p[1] * q[0] + p[2] * q[3] - p[3] * q[2]
    o2 = p[0] * q[2] - p[1] * q[3] + p[2] * q[0] + p[3] * q[1]
    o3 = p[0] * q[3] + p[1] * q[2] - p[2] * q[1] + p[3] * q[0]
    out[0] = o0
    out[1] = o1
    out[2] = o2
    out[3] = o3


@njit(cache=True)
def quat_normalize(q):
    """Scale ``q`` to unit length in place."""
    s = 1.0 / np.sqrt(q[0] ** 2 + q[1] ** 2 + q[2] ** 2 + q[3] ** 2)
    for i in range(4):
        q[i] *= s


@loop_kernel
def quat_to_matrix(q, R):
    """Rotation matrix of the unit quaternion ``q`` into ``R`` (3x3)."""
    q0, q1, q2, q3 = q[0], q[1], q[2], q[3]
    R[0, 0] = q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3
    R[0, 1] = 2.0 * (q1 * q2 - q0 * q3)
    R[0, 2] = 2.0 * (q1 * q3 + q0 * q2)
    R[1, 0] = 2.0 * (q1 * q2 + q0 * q3)
    R[1, 1] = q0 * q0 - q1 * q1 + q2 * q2 - q3 * q3
    R[1, 2] = 2.0 * (q2 * q3 - q0 * q1)
    R[2, 0] = 2.0 * (q1 * q3 - q0 * q2)
    R[2, 1] = 2.0 * (q2 * q3 + q0 * q1)
    R[2, 2] = q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3


@njit(cache=True, inline="always")
def matrix_to_quat(R, q):
    """Unit quaternion of the rotation matrix ``R`` (Shepperd's method, stable for all R)."""
    tr = R[0, 0] + R[1, 1] + R[2, 2]
    k = 0
    big = tr
    for i in range(3):
        if R[i, i] > big:
            big = R[i, i]
            k = i + 1
    if k == 0:
        s = 2.0 * np.sqrt(1.0 + tr)
        q[0] = 0.25 * s
        q[1] = (R[2, 1] - R[1, 2]) / s
        q[2] = (R[0, 2] - R[2, 0]) / s
        q[3] = (R[1, 0] - R[0, 1]) / s
    elif k == 1:
        s = 2.0 * np.sqrt(1.0 + 2.0 * R[0, 0] - tr)
        q[0] = (R[2, 1] - R[1, 2]) / s
        q[1] = 0.25 * s
        q[2] = (R[0, 1] + R[1, 0]) / s
        q[3] = (R[0, 2] + R[2, 0]) / s
    elif k == 2:
        s = 2.0 * np.sqrt(1.0 + 2.0 * R[1, 1] - tr)
        q[0] = (R[0, 2] - R[2, 0]) / s
        q[1] = (R[0, 1] + R[1, 0]) / s
        q[2] = 0.25 * s
        q[3] = (R[1, 2] + R[2, 1]) / s
    else:
        s = 2.0 * np.sqrt(1.0 + 2.0 * R[2, 2] - tr)
        q[0] = (R[1, 0] - R[0, 1]) / s
        q[1] = (R[0, 2] + R[2, 0]) / s
        q[2] = (R[1, 2] + R[2, 1]) / s
        q[3] = 0.25 * s
    quat_normalize(q)


@njit(cache=True)
def rotate_spatial(q, dw, work4):
    """Apply the spatial spin ``dw`` to ``q`` in place: R <- exp(S(dw)) R."""
    quat_from_rotvec(dw, work4)
    quat_mul(work4, q, q)
    quat_normalize(q)


@njit(cache=True, inline="always")
def log_matrix(R, theta, work4):
    """Rotation vector of the rotation matrix ``R`` (log map through a quaternion)."""
    matrix_to_quat(R, work4)
    rotvec_from_quat(work4, theta)


@njit(cache=True)
def ts_inverse_coeff(a):
    """(1 - (a/2) cot(a/2)) / a^2, smooth at a = 0."""
    if a < SERIES_ANGLE:
        return 1.0 / 12.0 + a * a / 720.0
    h = 0.5 * a
    return (1.0 - h / np.tan(h)) / (a * a)


@njit(cache=True)
def ts_inv(theta, out):
    """Inverse tangent operator Ts^-1(theta) = I - S/2 + c(a) S^2 (delta theta = Ts^-1 delta w)."""
    a = np.sqrt(theta[0] ** 2 + theta[1] ** 2 + theta[2] ** 2)
    c = ts_inverse_coeff(a)
    for i in range(3):
        for j in range(3):
            out[i, j] = c * (theta[i] * theta[j] - (a * a if i == j else 0.0))
        out[i, i] += 1.0
    out[0, 1] += 0.5 * theta[2]
    out[0, 2] -= 0.5 * theta[1]
    out[1, 0] -= 0.5 * theta[2]
    out[1, 2] += 0.5 * theta[0]
    out[2, 0] += 0.5 * theta[1]
    out[2, 1] -= 0.5 * theta[0]


@njit(cache=True)
def ts(theta, out):
    """Tangent operator Ts(theta) = I + (1-cos a)/a^2 S + (a - sin a)/a^3 S^2."""
    a = np.sqrt(theta[0] ** 2 + theta[1] ** 2 + theta[2] ** 2)
    if a < SERIES_ANGLE:
        c1 = 0.5 - a * a / 24.0 + a**4 / 720.0
        c2 = 1.0 / 6.0 - a * a / 120.0 + a**4 / 5040.0
    else:
        c1 = (1.0 - np.cos(a)) / (a * a)
        c2 = (a - np.sin(a)) / (a * a * a)
    for i in range(3):
        for j in range(3):
            out[i, j] = c2 * (theta[i] * theta[j] - (a * a if i == j else 0.0))
        out[i, i] += 1.0
    out[0, 1] -= c1 * theta[2]
    out[0, 2] += c1 * theta[1]
    out[1, 0] += c1 * theta[2]
    out[1, 2] -= c1 * theta[0]
    out[2, 0] -= c1 * theta[1]
    out[2, 1] += c1 * theta[0]


@njit(cache=True)
def kh_matrix(theta, v, tinv, m, out):
    """Kh = d(Ts^-T(theta) v)/d theta . Ts^-1(theta)  (Battini & Pacoste 2002, eq. for K_h).

    ``tinv`` must hold Ts^-1(theta); ``m`` is a 3x3 work array.  Closed form:
    [eta (theta v^T - 2 v theta^T + (theta.v) I) + mu S(theta)^2 v theta^T - S(v)/2] Ts^-1.
    """
    a = np.sqrt(theta[0] ** 2 + theta[1] ** 2 + theta[2] ** 2)
    if a < SERIES_ANGLE:
        eta = 1.0 / 12.0 + a * a / 720.0
        mu = 1.0 / 360.0 + a * a / 7560.0
    else:
        s2 = np.sin(0.5 * a)
        eta = (2.0 * np.sin(a) - a * (1.0 + np.cos(a))) / (2.0 * a * a * np.sin(a))
        mu = (a * (a + np.sin(a)) - 8.0 * s2 * s2) / (4.0 * a ** 4 * s2 * s2)
    tv = theta[0] * v[0] + theta[1] * v[1] + theta[2] * v[2]
    # S(theta)^2 v = theta (theta.v) - a^2 v
    s2v0 = theta[0] * tv - a * a * v[0]
    s2v1 = theta[1] * tv - a * a * v[1]
    s2v2 = theta[2] * tv - a * a * v[2]
    s2v = (s2v0, s2v1, s2v2)
    for i in range(3):
        for j in range(3):
            m[i, j] = eta * (theta[i] * v[j] - 2.0 * v[i] * theta[j]) + mu * s2v[i] * theta[j]
        m[i, i] += eta * tv
    m[0, 1] += 0.5 * v[2]
    m[0, 2] -= 0.5 * v[1]
    m[1, 0] -= 0.5 * v[2]
    m[1, 2] += 0.5 * v[0]
    m[2, 0] += 0.5 * v[1]
    m[2, 1] -= 0.5 * v[0]
    for i in range(3):
        for j in range(3):
            s = 0.0
            for k in range(3):
                s += m[i, k] * tinv[k, j]
            out[i, j] = s


@njit(cache=True)
def rotate_nodes(quat, dw):
    """Apply the spatial spins ``dw`` (n, 3) to the nodal quaternions ``quat`` (n, 4)."""
    work4 = np.empty(4)
    for k in range(quat.shape[0]):
        rotate_spatial(quat[k], dw[k], work4)


@njit(cache=True)
def spun_quat(q0, q1, q2, q3, w0, w1, w2):
    """The unit quaternion ``q`` after the spatial spin ``w``, exp(S(w)) q normalised: the
    arithmetic of :func:`rotate_spatial` on scalars (kept in registers in a node loop)."""
    a = np.sqrt(w0 ** 2 + w1 ** 2 + w2 ** 2)
    if a < SMALL_ANGLE:
        s = 0.5 - a * a / 48.0
        p0 = 1.0 - a * a / 8.0
    else:
        s = np.sin(0.5 * a) / a
        p0 = np.cos(0.5 * a)
    p1, p2, p3 = s * w0, s * w1, s * w2
    o0 = p0 * q0 - p1 * q1 - p2 * q2 - p3 * q3
    o1 = p0 * q1 + p1 * q0 + p2 * q3 - p3 * q2
    o2 = p0 * q2 - p1 * q3 + p2 * q0 + p3 * q1
    o3 = p0 * q3 + p1 * q2 - p2 * q1 + p3 * q0
    r = 1.0 / np.sqrt(o0 ** 2 + o1 ** 2 + o2 ** 2 + o3 ** 2)
    return o0 * r, o1 * r, o2 * r, o3 * r


@njit(cache=True)
def move_nodes(x, quat, du, n_rot):
    """One explicit drift of the nodes: ``x += du[:, :3]`` for every node (x (n, 3)),
    and the spatial spins ``du[:n_rot, 3:]`` applied to ``quat[:n_rot]`` as
    :func:`rotate_nodes` does (same arithmetic, :func:`spun_quat`)."""
    for i in range(x.shape[0]):
        for k in range(3):
            x[i, k] += du[i, k]
    for i in range(n_rot):
        quat[i, 0], quat[i, 1], quat[i, 2], quat[i, 3] = spun_quat(
            quat[i, 0], quat[i, 1], quat[i, 2], quat[i, 3], du[i, 3], du[i, 4], du[i, 5])


@njit(cache=True)
def in_plane_angle(q):
    """Angle of the rotated x axis about z, atan2(R10, R00) (planar problems)."""
    r00 = q[0] * q[0] + q[1] * q[1] - q[2] * q[2] - q[3] * q[3]
    r10 = 2.0 * (q[1] * q[2] + q[0] * q[3])
    return np.arctan2(r10, r00)
