"""Fibre section of a solid circular beam and the uniaxial J2 fibre law.

Section quadrature (polar product rule): Gauss-Legendre in the radius with the
Jacobian ``r`` folded into the weights, times the midpoint (trapezoidal) rule in
the angle.  With ``n_rings`` >= 2 and ``n_sectors`` >= 3 it integrates the area,
the first and the second moments of the disc exactly (A = pi r^2,
I = pi r^4 / 4); plastic resultants converge as the rule is refined.

Fibre law: 1D return mapping of J2 plasticity with the isotropic power-law
hardening of eq. 2 (sigma_Y + K eps_p^n), no kinematic hardening; the scalar
return is :func:`harnesspipe.fe.materials.hardening.return_map` with ``c = E``;
the consistent tangent is ``E H / (E + H)`` with ``H`` the hardening slope
(Simo & Hughes 1998, sec. 1.4).  Shear and torsion stay elastic.  Since the flow
stress never falls below sigma_Y, a fibre whose trial stress is within +-sigma_Y is
elastic without evaluating eq. 2 (most of the section at any time).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from harnesspipe.fe.materials.hardening import return_map


class FibreSection(NamedTuple):
    """Fibre section of an element (:func:`disc_fibres`)."""
    y: np.ndarray           # (nf,) fibre coordinates in the section
    z: np.ndarray           # (nf,)
    area: np.ndarray        # (nf,) fibre areas
    GJ: float               # torsional stiffness (elastic torsion)


class FibreMaterial(NamedTuple):
    """Eq. 2 J2 material of the fibres."""
    E: float
    sigma_y: float
    K: float
    n: float


class FibreHistory(NamedTuple):
    """Fibre history of one element: committed arrays read, trial arrays written."""
    eps_p_old: np.ndarray   # (ng, nf) signed plastic strain
    alpha_old: np.ndarray   # (ng, nf) accumulated plastic strain
    eps_p_new: np.ndarray   # (ng, nf)
    alpha_new: np.ndarray   # (ng, nf)


def disc_fibres(radius: float, n_rings: int = 4, n_sectors: int = 16):
    """Fibre coordinates ``y, z`` and areas ``A`` of a disc of ``radius``.

    Rings at the Gauss-Legendre points of [0, radius] (weight ``r dr``), each split
    into ``n_sectors`` equal sectors whose centres are offset by half a sector, so no
    fibre sits on a symmetry axis.
    """
    if n_rings < 1 or n_sectors < 3:
        raise ValueError("disc_fibres needs n_rings >= 1 and n_sectors >= 3")
    x, w = np.polynomial.legendre.leggauss(n_rings)
    r = 0.5 * radius * (1.0 + x)
    w_r = 0.5 * radius * w * r                      # int_0^R f(r) r dr
    theta = (np.arange(n_sectors) + 0.5) * (2.0 * np.pi / n_sectors)
    y = np.outer(r, np.cos(theta)).ravel()
    z = np.outer(r, np.sin(theta)).ravel()
    area = np.repeat(w_r * (2.0 * np.pi / n_sectors), n_sectors)
    return y, z, area


@njit(cache=True)
def fibre_update(eps, eps_p_old, alpha_old, E, sigma_y, K, n, elastic):
    """Uniaxial J2 return mapping with eq. 2 isotropic hardening.

    ``eps_p_old`` is the signed plastic strain, ``alpha_old`` the accumulated
    (equivalent) plastic strain.  Returns ``(sigma, E_t, eps_p, alpha)``.
    """
    sigma_trial = E * (eps - eps_p_old)
    q_trial = abs(sigma_trial)
    if elastic or q_trial <= sigma_y:
        return sigma_trial, E, eps_p_old, alpha_old
    dgamma, H = return_map(q_trial, E, alpha_old, sigma_y, K, n)
    if dgamma <= 0.0:
        return sigma_trial, E, eps_p_old, alpha_old
    sign = 1.0 if sigma_trial >= 0.0 else -1.0
    return (sigma_trial - sign * E * dgamma, E * H / (E + H), eps_p_old + sign * dgamma,
            alpha_old + dgamma)


@njit(cache=True)
def section_response(e0, kappa_y, kappa_z, sec, mat, elastic, hist, g, s, D):
    """Resultants of the fibre section for the generalised strains (e0, kappa_y, kappa_z).

    Fibre strain ``eps = e0 + z kappa_y - y kappa_z``.  Writes the stress resultants
    ``s = (N, M_y, M_z)`` with ``M_y = int sigma z dA``, ``M_z = -int sigma y dA``
    and the section tangent ``D = ds/de`` (3x3); trial history of Gauss point ``g`` into
    ``hist.*_new[g]``.  ``sec`` a :class:`FibreSection`, ``mat`` a :class:`FibreMaterial`,
    ``hist`` a :class:`FibreHistory`; ``elastic`` skips the return map.
    """
    y, z, area = sec.y, sec.z, sec.area
    E, sigma_y, K, n = mat
    eps_p_old, alpha_old = hist.eps_p_old[g], hist.alpha_old[g]
    eps_p_new, alpha_new = hist.eps_p_new[g], hist.alpha_new[g]
    s0 = s1 = s2 = 0.0
    d00 = d01 = d02 = d11 = d12 = d22 = 0.0
    for f in range(y.shape[0]):
        yf = y[f]
        zf = z[f]
        ep = eps_p_old[f]
        al = alpha_old[f]
        sig = E * (e0 + zf * kappa_y - yf * kappa_z - ep)
        Et = E
        if not elastic and abs(sig) > sigma_y:      # possibly plastic: eq. 2 return
            dg, H = return_map(abs(sig), E, al, sigma_y, K, n)
            if dg > 0.0:
                dgs = dg if sig >= 0.0 else -dg
                sig -= E * dgs
                ep += dgs
                al += dg
                Et = E * H / (E + H)
        eps_p_new[f] = ep
        alpha_new[f] = al
        a = area[f]
        sa = sig * a
        s0 += sa
        s1 += sa * zf
        s2 -= sa * yf
        ka = Et * a
        kz = ka * zf
        ky = ka * yf
        d00 += ka
        d01 += kz
        d02 -= ky
        d11 += kz * zf
        d12 -= kz * yf
        d22 += ky * yf
    s[0] = s0
    s[1] = s1
    s[2] = s2
    D[0, 0] = d00
    D[0, 1] = D[1, 0] = d01
    D[0, 2] = D[2, 0] = d02
    D[1, 1] = d11
    D[1, 2] = D[2, 1] = d12
    D[2, 2] = d22
