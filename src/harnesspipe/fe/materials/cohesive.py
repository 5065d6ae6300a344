"""Cohesive interface law of Sec. 4.1: eqs. 7-10 (tape-to-wire / tape-to-tube bonding).

Elastic part, eq. 7.  Uncoupled traction-separation, ``t_i = K_ii delta_i`` for
``i = n, s, t`` (``K_ns = K_nt = K_st = 0``), with ``delta = u+ - u-`` in the local
(normal, shear 1, shear 2) frame of the interface.

Damage initiation, eq. 8 (maximum separation).  Damage starts when

    max{ <delta_n>/delta_n^0, |delta_s|/delta_s^0, |delta_t|/delta_t^0 } = 1,

with ``<x> = max(x, 0)`` (Macaulay bracket): a compressed interface does not damage.

Effective separation.  ``delta_m = sqrt(<delta_n>^2 + delta_s^2 + delta_t^2)``.  For
the current mode mix ``m = (<delta_n>, |delta_s|, |delta_t|) / delta_m`` the
criterion of eq. 8 is met at the effective separation

    delta_m^0 = 1 / max_i( m_i / delta_i^0 ),

which reduces to ``delta_n^0`` in pure opening and ``delta_s^0`` in pure shear.

Damage evolution, eqs. 9-10 (exponential softening).  ``t_i = (1 - D) t_i^*`` with
the elastic trial traction ``t_i^*`` of eq. 7 and, for ``delta_m^0 < kappa < delta_m^f``,

    D = 1 - (delta_m^0 / kappa) [1 - (1 - exp(-alpha x)) / (1 - exp(-alpha))],
    x = (kappa - delta_m^0) / (delta_m^f - delta_m^0),

``D = 0`` for ``kappa <= delta_m^0`` and ``D = 1`` for ``kappa >= delta_m^f``.  The
history variable ``kappa`` is the largest effective separation reached so far.  Damage
is updated only while loading (``delta_m > kappa``), so unloading and reloading follow
the damaged secant ``t = (1 - D) K delta`` with ``D`` frozen.  ``D`` is also kept as a
history variable and never decreases (a change of mode mix that moves ``delta_m^0``
could otherwise lower eq. 10's value).  The normal
traction in compression, ``delta_n < 0``, is ``K_nn delta_n`` whatever ``D``.

The evolution rate must be positive, ``alpha > 0``.  Paper values (DESIGN sec. 3):
``K_nn = K_ss = K_tt = 30 N/mm^3``, ``delta^0 = 0.03 mm``, ``delta_m^f = 0.08 mm``,
``alpha = 2``.
"""
from __future__ import annotations

import math

from numba import njit


@njit(cache=True, inline="always")
def exponential_damage(kappa, delta_m0, delta_mf, alpha):
    """Damage ``D`` of eq. 10 at the largest effective separation ``kappa`` reached.

    Returns 0 up to the onset ``delta_m0``, 1 at and beyond failure ``delta_mf``.
    """
    if kappa <= delta_m0:
        return 0.0
    if kappa >= delta_mf:
        return 1.0
    x = (kappa - delta_m0) / (delta_mf - delta_m0)
    decay = (1.0 - math.exp(-alpha * x)) / (1.0 - math.exp(-alpha))
    return 1.0 - (delta_m0 / kappa) * (1.0 - decay)


@njit(cache=True, inline="always")
def onset_separation(delta, delta0):
    """Effective separation ``delta_m^0`` at which eq. 8 is met for the mode mix of ``delta``.

    ``delta`` (3,) is (n, s, t); ``delta0`` (3,) the per-direction onset separations.
    Returns 0 when the effective separation is zero (no mode mix defined).
    """
    dn = max(delta[0], 0.0)
    ds = abs(delta[1])
    dt = abs(delta[2])
    dm = math.sqrt(dn * dn + ds * ds + dt * dt)
    if dm == 0.0:
        return 0.0
    ratio = max(dn / delta0[0], max(ds / delta0[1], dt / delta0[2]))
    return dm / ratio


@njit(cache=True, inline="always")
def cohesive_traction(delta, K, delta0, delta_mf, alpha, kappa_old, D_old, t):
    """Traction of the damaged cohesive law (eqs. 7-10) and the updated history.

    Parameters
    ----------
    delta : (3,) separation (n, s, t) = u+ - u- in the interface frame (mm).
    K : (3,) diagonal stiffness (K_nn, K_ss, K_tt) (N/mm^3).
    delta0 : (3,) onset separations of eq. 8 per direction (mm).
    delta_mf : effective separation at complete failure, eq. 10 (mm).
    alpha : exponential damage evolution rate of eq. 10 (> 0).
    kappa_old, D_old : committed history (largest delta_m reached; damage).
    t : (3,) output, traction (N/mm^2).

    Returns
    -------
    (D, kappa) : the damage and the largest effective separation after this state.
    """
    dn = max(delta[0], 0.0)
    dm = math.sqrt(dn * dn + delta[1] * delta[1] + delta[2] * delta[2])
    kappa = kappa_old
    D = D_old
    if dm > kappa_old:
        kappa = dm
        D = max(D_old, exponential_damage(dm, onset_separation(delta, delta0), delta_mf, alpha))
    if delta[0] < 0.0:
        t[0] = K[0] * delta[0]
    else:
        t[0] = (1.0 - D) * K[0] * delta[0]
    t[1] = (1.0 - D) * K[1] * delta[1]
    t[2] = (1.0 - D) * K[2] * delta[2]
    return D, kappa


@njit(cache=True)
def cohesive_dissipated_energy(K, delta_m0, delta_mf, alpha, kappa):
    """Energy per unit area dissipated by one-mode loading to ``kappa`` (N/mm), eqs. 7-10.

    For a proportional path of stiffness ``K`` (pure opening: ``K_nn``, pure shear:
    ``K_ss``) it is the work done along the envelope up to ``kappa`` minus the elastic
    energy ``(1 - D) K kappa^2 / 2`` recovered on unloading along the secant.  The
    envelope beyond the onset is ``(1 - D) K delta = K delta_m0 [1 - (1 - e^(-alpha x))
    / (1 - e^(-alpha))]``, whose integral is closed form.  At ``kappa >= delta_mf``
    this is the work of separation

        G_c = K delta_m0 [delta_m0 / 2 + (delta_mf - delta_m0) (1/alpha - 1/(e^alpha - 1))].
    """
    k = min(kappa, delta_mf)
    if k <= delta_m0:
        return 0.0
    L = delta_mf - delta_m0
    X = (k - delta_m0) / L
    shape = X - (X - (1.0 - math.exp(-alpha * X)) / alpha) / (1.0 - math.exp(-alpha))
    envelope_work = 0.5 * K * delta_m0 * delta_m0 + K * delta_m0 * L * shape
    D = exponential_damage(k, delta_m0, delta_mf, alpha)
    return envelope_work - 0.5 * (1.0 - D) * K * k * k
