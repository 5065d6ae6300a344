"""Finite elements: the co-rotational fibre beam (implicit tangent and explicit forces with
its lumped mass), the finite-strain quad shell, the Belytschko-Lin-Tsay shell for explicit
dynamics, the axisymmetric shell, and the branch joint's bushing and strand truss."""
