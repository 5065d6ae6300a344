"""Geometry of bilinear shell quads as contact surfaces: points, tangents and normals at
(xi, eta), and the closest-point projection of a point.

Node order of a quad: counter-clockwise, corners (xi, eta) = (-1, -1), (1, -1), (1, 1),
(-1, 1); the unit normal is X_xi x X_eta normalised.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from harnesspipe.fe.loops import loop_kernel
from harnesspipe.fe.vec3 import dot


@njit(cache=True, inline="always")
def quad_tangents(x, quads, q, xi, eta, X, X_xi, X_eta):
    """Point X and tangents X_xi, X_eta of the bilinear quad q at (xi, eta) (written)."""
    for k in range(3):
        X[k] = 0.0
        X_xi[k] = 0.0
        X_eta[k] = 0.0
    for m in range(4):
        sx = -1.0 if (m == 0 or m == 3) else 1.0
        se = -1.0 if (m == 0 or m == 1) else 1.0
        Nm = 0.25 * (1 + sx * xi) * (1 + se * eta)
        dx = 0.25 * sx * (1 + se * eta)
        de = 0.25 * se * (1 + sx * xi)
        for k in range(3):
            c = x[quads[q, m], k]
            X[k] += Nm * c
            X_xi[k] += dx * c
            X_eta[k] += de * c


@njit(cache=True, inline="always")
def quad_eval(x, quads, q, xi, eta, X, n, e1):
    """Point X, unit normal n = unit(X_xi x X_eta), unit tangent e1 = unit(X_xi) (written)."""
    quad_tangents(x, quads, q, xi, eta, X, e1, n)    # X_eta kept in n for now
    c0 = e1[1] * n[2] - e1[2] * n[1]
    c1 = e1[2] * n[0] - e1[0] * n[2]
    c2 = e1[0] * n[1] - e1[1] * n[0]
    nn = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
    n[0] = c0 / nn
    n[1] = c1 / nn
    n[2] = c2 / nn
    le = math.sqrt(dot(e1, e1))
    for k in range(3):
        e1[k] /= le


def quad_point(x, quads, q, xi, eta):
    """Point, unit normal (X_xi x X_eta) and unit tangent X_xi of quad q at (xi, eta)."""
    X = np.empty(3)
    n = np.empty(3)
    e1 = np.empty(3)
    quad_eval(np.asarray(x, dtype=float), np.asarray(quads, dtype=np.int64), q, xi, eta, X, n, e1)
    return X, n, e1


@loop_kernel
def project_quad(x, quads, q, p, clamp, out):
    """Closest point parameters of point p on quad q by Gauss-Newton (at most 7 iterations).

    ``clamp``: keep (xi, eta) in [-1, 1]^2 (projected iterations).  Writes
    out = (xi, eta, X(3), n(3)) as out[0:2], out[2:5], out[5:8]; unit normal X_xi x X_eta.
    """
    xi = 0.0
    eta = 0.0
    i0 = quads[q, 0]                # nodes indexed in place (a view per call costs its
    i1 = quads[q, 1]                # reference count)
    i2 = quads[q, 2]
    i3 = quads[q, 3]
    done = False
    for it in range(8):
        a0 = 0.25 * (1 - xi) * (1 - eta)
        a1 = 0.25 * (1 + xi) * (1 - eta)
        a2 = 0.25 * (1 + xi) * (1 + eta)
        a3 = 0.25 * (1 - xi) * (1 + eta)
        bx0 = -0.25 * (1 - eta)
        bx1 = 0.25 * (1 - eta)
        bx2 = 0.25 * (1 + eta)
        bx3 = -0.25 * (1 + eta)
        be0 = -0.25 * (1 - xi)
        be1 = -0.25 * (1 + xi)
        be2 = 0.25 * (1 + xi)
        be3 = 0.25 * (1 - xi)
        Xs0 = a0 * x[i0, 0] + a1 * x[i1, 0] + a2 * x[i2, 0] + a3 * x[i3, 0]
        Xs1 = a0 * x[i0, 1] + a1 * x[i1, 1] + a2 * x[i2, 1] + a3 * x[i3, 1]
        Xs2 = a0 * x[i0, 2] + a1 * x[i1, 2] + a2 * x[i2, 2] + a3 * x[i3, 2]
        tx0 = bx0 * x[i0, 0] + bx1 * x[i1, 0] + bx2 * x[i2, 0] + bx3 * x[i3, 0]
        tx1 = bx0 * x[i0, 1] + bx1 * x[i1, 1] + bx2 * x[i2, 1] + bx3 * x[i3, 1]
        tx2 = bx0 * x[i0, 2] + bx1 * x[i1, 2] + bx2 * x[i2, 2] + bx3 * x[i3, 2]
        te0 = be0 * x[i0, 0] + be1 * x[i1, 0] + be2 * x[i2, 0] + be3 * x[i3, 0]
        te1 = be0 * x[i0, 1] + be1 * x[i1, 1] + be2 * x[i2, 1] + be3 * x[i3, 1]
        te2 = be0 * x[i0, 2] + be1 * x[i1, 2] + be2 * x[i2, 2] + be3 * x[i3, 2]
        if done or it == 7:
            break
        r0 = p[0] - Xs0
        r1 = p[1] - Xs1
        r2 = p[2] - Xs2
        A = tx0 * tx0 + tx1 * tx1 + tx2 * tx2
        B = tx0 * te0 + tx1 * te1 + tx2 * te2
        C = te0 * te0 + te1 * te1 + te2 * te2
        g0 = tx0 * r0 + tx1 * r1 + tx2 * r2
        g1 = te0 * r0 + te1 * r1 + te2 * r2
        det = A * C - B * B
        if det <= 0.0:
            break
        dxi = (C * g0 - B * g1) / det
        deta = (A * g1 - B * g0) / det
        xi += dxi
        eta += deta
        if clamp:
            xi = min(1.0, max(-1.0, xi))
            eta = min(1.0, max(-1.0, eta))
        else:   # keep the iteration bounded for far-off points
            xi = min(3.0, max(-3.0, xi))
            eta = min(3.0, max(-3.0, eta))
        done = abs(dxi) + abs(deta) < 1e-10   # refresh the point once more, then stop
    out[0] = xi
    out[1] = eta
    out[2] = Xs0
    out[3] = Xs1
    out[4] = Xs2
    n0 = tx1 * te2 - tx2 * te1
    n1 = tx2 * te0 - tx0 * te2
    n2 = tx0 * te1 - tx1 * te0
    nn = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    out[5] = n0 / nn
    out[6] = n1 / nn
    out[7] = n2 / nn
