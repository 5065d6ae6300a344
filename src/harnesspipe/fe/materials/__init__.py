"""Constitutive laws at a point: power-law hardening (eq. 2), the J2 fibre and the fibre
section of the beams, plane-stress J2 and the orthotropic fabric (eqs. 1-2, 12), the
cohesive traction-separation law (eqs. 7-10) and the rate-dependent friction (eq. 6)."""
