"""Rate-dependent Coulomb friction of eq. 6 with a penalty-regularised stick/slip return map.

Friction coefficient, eq. 6 (wire-wire contact, Sec. 4.1):

    mu = mu_k + (mu_s - mu_k) exp(-d_c gamma_dot),

decaying from the static ``mu_s`` at rest to the kinetic ``mu_k`` in fast sliding.
``gamma_dot = sqrt(gamma_dot_1^2 + gamma_dot_2^2)`` is the equivalent slip rate
from the two slip velocities along the local tangents of the contact surface (the
paper's ``sqrt(gamma_dot_1 + gamma_dot_2)`` drops the squares).

Physical time.  ``d_c`` carries units of time (s, paper: d_c = 2 with
mu_s = 0.4, mu_k = 0.1), so ``gamma_dot`` must be a rate in PHYSICAL time.  A run
that shortens its time axis (time scaling) or that is mass scaled so that it may be
run faster must convert: the caller passes the physical time increment ``dt_phys``
(or the physical slip rate), never the solver's scaled increment.

Stick/slip, return mapping (penalty regularisation; e.g. Wriggers, Computational
Contact Mechanics, 2006).
With tangential penalty ``k_t`` and the tangential relative displacement increment
``dg`` of the contact point, the trial force is ``f_tr = f_old + k_t dg``.  If
``|f_tr| <= mu f_n`` the point sticks (``f = f_tr``, no slip; its elastic
tangential displacement ``|f| / k_t <= mu f_n / k_t`` is the regularisation error).
Otherwise it slips: ``f = mu f_n f_tr / |f_tr|`` and the slip increment
``ds = (|f_tr| - mu f_n) / k_t  f_tr / |f_tr|`` is parallel to ``f``.  The energy
dissipated in the increment is ``f . ds = mu f_n |ds|``.  ``f`` points along the
relative motion ``dg`` that builds it: the body that moves by ``dg`` receives ``-f``.
"""
from __future__ import annotations

import math

from numba import njit


@njit(cache=True, inline="always")
def friction_coefficient(mu_s, mu_k, d_c, slip_rate):
    """Friction coefficient of eq. 6 at the equivalent slip rate ``slip_rate`` (physical time)."""
    return mu_k + (mu_s - mu_k) * math.exp(-d_c * slip_rate)


@njit(cache=True)
def equivalent_slip_rate(gamma_dot_1, gamma_dot_2):
    """Equivalent slip rate ``sqrt(gamma_dot_1^2 + gamma_dot_2^2)`` of eq. 6."""
    return math.sqrt(gamma_dot_1 * gamma_dot_1 + gamma_dot_2 * gamma_dot_2)


@njit(cache=True, inline="always")
def coulomb_return_map(f_old, dg, k_t, mu, f_n, f_new, ds):
    """Penalty stick/slip update of a tangential contact force at a given ``mu``.

    Parameters
    ----------
    f_old : (m,) committed tangential force (m = 2 for a surface, 1 along a line).
    dg : (m,) increment of tangential relative displacement.
    k_t : tangential penalty stiffness (N/mm).
    mu : friction coefficient.
    f_n : normal contact force (N, compressive positive; a negative value is no contact).
    f_new : (m,) output, updated tangential force.
    ds : (m,) output, slip increment (zero while sticking).

    Returns
    -------
    (slipping, dW) : whether the point slips; energy dissipated in the increment (N mm).
    """
    m = f_old.shape[0]
    norm2 = 0.0
    for i in range(m):
        f_new[i] = f_old[i] + k_t * dg[i]
        norm2 += f_new[i] * f_new[i]
    norm = math.sqrt(norm2)
    limit = mu * max(f_n, 0.0)
    if norm <= limit:
        for i in range(m):
            ds[i] = 0.0
        return False, 0.0
    scale = limit / norm
    slip = (norm - limit) / k_t
    for i in range(m):
        direction = f_new[i] / norm
        f_new[i] *= scale
        ds[i] = slip * direction
    return True, limit * slip


@njit(cache=True, inline="always")
def rate_dependent_friction(f_old, dg, dt_phys, k_t, mu_s, mu_k, d_c, f_n, f_new, ds):
    """Eq. 6 friction update of one contact point over a step of PHYSICAL duration ``dt_phys``.

    The equivalent slip rate is the tangential relative speed ``|dg| / dt_phys`` over
    the increment; ``mu`` follows from eq. 6 and the force from
    :func:`coulomb_return_map`.  With time or mass scaling pass the physical step,
    not the solver's.  Returns ``(mu, slipping, dW)``.
    """
    norm2 = 0.0
    for i in range(dg.shape[0]):
        norm2 += dg[i] * dg[i]
    mu = friction_coefficient(mu_s, mu_k, d_c, math.sqrt(norm2) / dt_phys)
    slipping, dW = coulomb_return_map(f_old, dg, k_t, mu, f_n, f_new, ds)
    return mu, slipping, dW
