"""4-node shell and axisymmetric shell against analytic and published results."""
import numpy as np
import pytest
from scipy.optimize import brentq

import harnesspipe  # noqa: F401  (sets the Numba cache)
from harnesspipe.fe.elements.shell import DOF_PER_NODE, Shell, lumped_mass
from harnesspipe.fe.elements.shell_axisym import AxisymShell
from harnesspipe.fe.materials.hardening import flow_stress
from harnesspipe.fe.solvers.static_dense import Controls, solve

BIG = 1e30  # yield stress of an elastic material


def grid(xs, ys, surface=lambda x, y: (x, y, 0.0)):
    """Structured quadrilateral mesh of the parameter grid xs x ys mapped by ``surface``."""
    X = np.array([surface(x, y) for y in ys for x in xs], dtype=float)
    nx = len(xs)
    conn = np.array([[j * nx + i, j * nx + i + 1, (j + 1) * nx + i + 1, (j + 1) * nx + i]
                     for j in range(len(ys) - 1) for i in range(nx - 1)])
    return X, conn


def dofs(nodes, components):
    return np.array([DOF_PER_NODE * a + c for a in np.atleast_1d(nodes) for c in components], int)


def linear_solution(model, prescribed: dict, loads=None):
    """Small-displacement solution: one solve with the tangent at the reference state."""
    K, f = model.tangent_and_force()
    K = K.toarray()
    u = np.zeros(model.n_dof)
    fixed = np.array(sorted(prescribed), int)
    u[fixed] = [prescribed[k] for k in fixed]
    free = np.setdiff1d(np.arange(model.n_dof), fixed)
    rhs = (np.zeros(model.n_dof) if loads is None else loads)[free] - K[np.ix_(free, fixed)] @ u[fixed]
    u[free] = np.linalg.solve(K[np.ix_(free, free)], rhs)
    return u


def uniaxial_force(stretch, E, nu, sigma_y, K, n, area0):
    """Closed-form 1D J2 in true stress and log strain, with the section shrinking by
    elastic Poisson and plastic incompressibility: F = sigma A, A = A0 exp(2 eps_lat)."""
    eps = np.log(stretch)
    if E * eps <= sigma_y:
        eps_p = 0.0
    else:
        eps_p = brentq(lambda ep: E * (eps - ep) - flow_stress(ep, sigma_y, K, n), 0.0, eps)
    tau = E * (eps - eps_p)                       # Kirchhoff stress of the Hencky model
    eps_lat = -nu * tau / E - 0.5 * eps_p
    J = np.exp(eps + 2.0 * eps_lat)
    return tau / J * area0 * np.exp(2.0 * eps_lat), eps_lat


@pytest.mark.parametrize("mat", [(1000.0, 0.3, BIG, 0.0, 1.0), (1559.0, 0.42, 8.6, 25.6, 0.12),
                                 (698.0, 0.42, 8.8, 23.1, 0.83)])
def test_strip_uniaxial_tension_matches_closed_form(mat):
    L, W, t, U = 10.0, 2.0, 0.27, 3.0
    X, conn = grid(np.linspace(0, L, 5), np.linspace(0, W, 3))
    model = Shell(X, conn, t, *mat)
    left, right = np.flatnonzero(X[:, 0] == 0), np.flatnonzero(X[:, 0] == L)
    fixed = np.concatenate([dofs(left, [0]), dofs(left[0], [1]),
                            dofs(np.arange(len(X)), [2, 3, 4, 5])])
    model.hold(fixed)
    out = []
    hist = solve(model, fixed, dofs(right, [0]), [U] * len(right), controls=Controls(n_steps=12),
                 on_step=lambda lam: out.append(model.h.mean()))
    for lam, force, h in zip(hist.lam[1:], hist.reaction[1:], out):
        exact, eps_lat = uniaxial_force(1 + lam * U / L, *mat, area0=W * t)
        assert force == pytest.approx(exact, rel=1e-3)
        assert h == pytest.approx(t * np.exp(eps_lat), rel=1e-3)


def test_axisymmetric_tube_tension_matches_closed_form():
    mat = (1559.0, 0.42, 8.6, 25.6, 0.12)
    R, t, L, U, ne = 6.2, 0.27, 10.0, 3.0, 8
    X = np.column_stack([np.full(ne + 1, R), np.linspace(0, L, ne + 1)])
    conn = np.column_stack([np.arange(ne), np.arange(1, ne + 1)])
    model = AxisymShell(X, np.zeros(ne + 1), conn, t, *mat)
    fixed = [1] + [3 * i + 2 for i in range(ne + 1)]
    hist = solve(model, fixed, [3 * ne + 1], [U], controls=Controls(n_steps=12))
    for lam, force in zip(hist.lam[1:], hist.reaction[1:]):
        exact, _ = uniaxial_force(1 + lam * U / L, *mat, area0=2 * np.pi * R * t)
        assert force == pytest.approx(exact, rel=1e-3)


# MacNeal & Harder (1985) patch: 0.24 x 0.12 with four distorted interior nodes
PATCH = np.array([[0, 0, 0], [0.24, 0, 0], [0.24, 0.12, 0], [0, 0.12, 0],
                  [0.04, 0.02, 0], [0.18, 0.03, 0], [0.16, 0.08, 0], [0.08, 0.08, 0]])
PATCH_CONN = np.array([[0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7], [4, 5, 6, 7]])


def test_membrane_patch():
    model = Shell(PATCH, PATCH_CONN, 0.001, 1e6, 0.25, BIG, 0.0, 1.0)
    exact = lambda x, y: (1e-3 * (x + y / 2), 1e-3 * (y + x / 2))  # noqa: E731
    prescribed = {k: 0.0 for k in dofs(range(8), [2, 3, 4])}
    for a in range(4):
        ux, uy = exact(*PATCH[a, :2])
        prescribed.update({6 * a: ux, 6 * a + 1: uy, 6 * a + 5: 0.0})
    u = linear_solution(model, prescribed).reshape(-1, 6)
    for a in range(4, 8):
        assert u[a, :2] == pytest.approx(exact(*PATCH[a, :2]), rel=1e-6, abs=1e-12)


def test_bending_patch():
    model = Shell(PATCH, PATCH_CONN, 0.001, 1e6, 0.25, BIG, 0.0, 1.0)
    w = lambda x, y: 1e-3 * (x * x + x * y + y * y) / 2  # noqa: E731
    rot = lambda x, y: (1e-3 * (y + x / 2), -1e-3 * (x + y / 2))  # noqa: E731  spin = e3 x grad(-w)
    prescribed = {k: 0.0 for k in dofs(range(8), [0, 1, 5])}
    for a in range(4):
        x, y = PATCH[a, :2]
        prescribed.update({6 * a + 2: w(x, y), 6 * a + 3: rot(x, y)[0], 6 * a + 4: rot(x, y)[1]})
    u = linear_solution(model, prescribed).reshape(-1, 6)
    for a in range(4, 8):
        x, y = PATCH[a, :2]
        assert u[a, 2] == pytest.approx(w(x, y), rel=1e-6)
        assert u[a, 3:5] == pytest.approx(rot(x, y), rel=1e-6)


def test_scordelis_lo_roof():
    """Scordelis-Lo roof, quarter model: vertical displacement at the midside of the free
    edge 0.3024 (MacNeal & Harder 1985, Finite Elem. Anal. Des. 1, 3-20, Table 6)."""
    R, half_length, angle, t, n = 25.0, 25.0, np.deg2rad(40.0), 0.25, 16
    X, conn = grid(np.linspace(0, angle, n + 1), np.linspace(0, half_length, n + 1),
                   lambda phi, y: (R * np.sin(phi), y, R * np.cos(phi)))
    model = Shell(X, conn, t, 4.32e8, 0.0, BIG, 0.0, 1.0)
    loads = np.zeros(model.n_dof)
    loads[2::6] = -90.0 / t * lumped_mass(X, conn, t, 1.0)[::6]  # 90 per unit area, downward
    diaphragm = np.flatnonzero(np.isclose(X[:, 1], 0.0))
    midspan = np.flatnonzero(np.isclose(X[:, 1], half_length))
    crown = np.flatnonzero(np.isclose(X[:, 0], 0.0))
    fixed = np.unique(np.concatenate([dofs(diaphragm, [0, 2, 4]), dofs(midspan, [1, 3, 5]),
                                      dofs(crown, [0, 4, 5])]))
    u = linear_solution(model, {k: 0.0 for k in fixed}, loads).reshape(-1, 6)
    edge_mid = np.flatnonzero(np.isclose(X[:, 1], half_length) & np.isclose(X[:, 0], R * np.sin(angle)))
    assert -u[edge_mid[0], 2] == pytest.approx(0.3024, rel=0.02)


def test_strip_rolled_into_a_circle_by_end_moment():
    """Cantilever under end moment M = 2 pi EI / L: the tip follows the circle of radius
    EI / M(lambda) and closes the ring at lambda = 1 (elastica, nu = 0)."""
    L, b, t, E = 12.0, 1.0, 0.1, 1.2e6
    X, conn = grid(np.linspace(0, L, 33), np.linspace(0, b, 2))
    model = Shell(X, conn, t, E, 0.0, BIG, 0.0, 1.0)
    EI = E * b * t**3 / 12
    clamp, tip = np.flatnonzero(X[:, 0] == 0), np.flatnonzero(X[:, 0] == L)
    fixed = dofs(clamp, range(6))
    model.hold(fixed)
    loads = np.zeros(model.n_dof)
    loads[dofs(tip, [4])] = -2 * np.pi * EI / L / len(tip)  # about -y: rolls towards +z
    path = []
    solve(model, fixed, loads=loads, controls=Controls(n_steps=20),
          on_step=lambda lam: path.append((lam, model.x[tip].mean(axis=0))))
    assert path[-1][0] == pytest.approx(1.0)
    for lam, p in path:
        kappa = lam * 2 * np.pi / L
        exact = (np.sin(kappa * L) / kappa, (1 - np.cos(kappa * L)) / kappa)
        assert np.hypot(p[0] - exact[0], p[2] - exact[1]) < 0.01 * L
    closed = path[-1][1]
    assert np.hypot(closed[0], closed[2]) < 0.01 * L  # back at the clamp


def test_axisymmetric_tangent_matches_finite_differences():
    """Analytic consistent tangent of the axisymmetric shell at a plastic, curved state."""
    from harnesspipe.models.tensile import TubeGeometry, meridian_mesh
    X, Phi, conn = meridian_mesh(TubeGeometry(), 6)
    model = AxisymShell(X, Phi, conn, 0.27, 1559.0, 0.42, 8.6, 25.6, 0.12)
    rng = np.random.default_rng(3)
    stretch = np.zeros(model.n_dof)
    stretch[1::3] = np.linspace(0.0, 0.3, 7)  # 20 % axial stretch of the half-pitch cell
    model.advance(stretch)
    model.tangent_and_force()
    model.accept()
    assert model.state[..., 4].max() > 0.01  # plastic
    model.advance(0.02 * rng.standard_normal(model.n_dof))
    K, f = model.tangent_and_force()
    K, f = K.copy(), f.copy()
    h = 1e-7
    for j in range(model.n_dof):
        du = np.zeros(model.n_dof)
        du[j] = h
        model.advance(du)
        fp = model.tangent_and_force()[1].copy()
        model.advance(-2 * du)
        fm = model.tangent_and_force()[1].copy()
        model.advance(du)
        assert np.allclose(K[:, j], (fp - fm) / (2 * h), rtol=1e-5, atol=1e-6 * np.abs(K).max())


def test_shell_explicit_force_and_mass():
    X, conn = grid(np.linspace(0, 4, 3), np.linspace(0, 2, 3), lambda x, y: (x, y, 0.1 * x * y))
    model = Shell(X, conn, 0.3, 1000.0, 0.3, 5.0, 10.0, 0.5)
    model.advance(0.05 * np.random.default_rng(4).standard_normal(model.n_dof))
    _, f = model.tangent_and_force()
    assert np.allclose(model.internal_force(), f, rtol=1e-12, atol=1e-12)
    m = lumped_mass(X, conn, 0.3, 2.0)
    area = sum(0.5 * np.linalg.norm(np.cross(X[c[2]] - X[c[0]], X[c[3]] - X[c[1]])) for c in conn)
    assert m[0::6].sum() == pytest.approx(2.0 * 0.3 * area)


# --- eq. 12 orthotropic elastic plane stress (fabric tube, Sec. 4.2.2) -------------
FABRIC = (93.5, 31.0, 0.3)  # E1 (Sec. 3.2), an illustrative weft E2, nu12


def orthotropic_strip(axis, L=10.0, W=2.0, t=0.3, U=0.01):
    """Linear response of a flat strip pulled along x by U, free lateral edges (uniaxial
    stress); returns (axial force, lateral strain, model)."""
    from harnesspipe.fe.materials.plane_stress import fabric_shear_modulus
    X, conn = grid(np.linspace(0, L, 5), np.linspace(0, W, 3))
    model = Shell.orthotropic(X, conn, t, *FABRIC, axis=axis)
    assert model.mat[3] == pytest.approx(fabric_shear_modulus(*FABRIC))
    left, right = np.flatnonzero(X[:, 0] == 0), np.flatnonzero(X[:, 0] == L)
    # drilling spins left free: under off-axis loading the strip shears and rotates
    prescribed = {k: 0.0 for k in np.concatenate([dofs(left, [0]), dofs(left[0], [1]),
                                                  dofs(np.arange(len(X)), [2, 3, 4])])}
    prescribed.update({k: U for k in dofs(right, [0])})
    u = linear_solution(model, prescribed)
    K, _ = model.tangent_and_force()
    force = (K @ u)[dofs(right, [0])].sum()
    top = np.flatnonzero(X[:, 1] == W)
    bottom = np.flatnonzero(X[:, 1] == 0)
    lateral = (u[dofs(top, [1])].mean() - u[dofs(bottom, [1])].mean()) / W
    return force, lateral, model


def test_orthotropic_strip_along_directions_1_and_2():
    E1, E2, nu12 = FABRIC
    L, W, t, U = 10.0, 2.0, 0.3, 0.01
    f1, lat1, _ = orthotropic_strip(None, L, W, t, U)            # default: local x = direction 1
    f2, lat2, _ = orthotropic_strip((0.0, 1.0, 0.0), L, W, t, U)  # axes turned by 90 deg
    assert f1 == pytest.approx(E1 * W * t * U / L, rel=1e-6)
    assert f2 == pytest.approx(E2 * W * t * U / L, rel=1e-6)
    assert f1 / f2 == pytest.approx(E1 / E2, rel=1e-6)
    assert lat1 == pytest.approx(-nu12 * U / L, rel=1e-6)
    assert lat2 == pytest.approx(-nu12 * E2 / E1 * U / L, rel=1e-6)  # nu21 = nu12 E2 / E1
    f1x, _, _ = orthotropic_strip((-3.0, 0.0, 0.0), L, W, t, U)      # sign and length irrelevant
    assert f1x == pytest.approx(f1, rel=1e-9)


@pytest.mark.parametrize("axis", [(1.0, 1.0, 0.0), (1.0, 1.0, 0.9)])  # second: projected
def test_orthotropic_strip_at_45_degrees_apparent_modulus(axis):
    from harnesspipe.fe.materials.plane_stress import fabric_shear_modulus
    E1, E2, nu12 = FABRIC
    G12 = fabric_shear_modulus(E1, E2, nu12)
    L, W, t, U = 10.0, 2.0, 0.3, 0.01
    force, _, model = orthotropic_strip(axis, L, W, t, U)
    assert np.allclose(model.axes[..., 0], np.sqrt(0.5)) and np.allclose(model.axes[..., 1], np.sqrt(0.5))
    E45 = 4.0 / (1 / E1 + 1 / E2 + 1 / G12 - 2 * nu12 / E1)
    assert force / (W * t * U / L) == pytest.approx(E45, rel=0.01)


@pytest.mark.parametrize("axis", [(1.0, 0.0, 0.0), (0.0, 1.0, 0.0)])
def test_orthotropic_simple_shear_patch_gives_G12(axis):
    """Distorted MacNeal-Harder patch in simple shear u = (gamma y, 0): interior nodes
    reproduce the field and the strain energy is G12 gamma^2 V / 2 (one axis for all
    elements: the default local x axes differ between the distorted elements)."""
    E1, E2, nu12, G12, t, gamma = *FABRIC, 17.0, 0.001, 1e-3
    model = Shell.orthotropic(PATCH, PATCH_CONN, t, E1, E2, nu12, G12, axis=axis)
    prescribed = {k: 0.0 for k in dofs(range(8), [2, 3, 4])}
    for a in range(4):
        prescribed.update({6 * a: gamma * PATCH[a, 1], 6 * a + 1: 0.0, 6 * a + 5: -gamma / 2})
    u = linear_solution(model, prescribed)
    for a in range(4, 8):
        assert u[6 * a:6 * a + 2] == pytest.approx((gamma * PATCH[a, 1], 0.0), abs=1e-9 * gamma)
    K, _ = model.tangent_and_force()
    energy = 0.5 * u @ (K @ u)
    assert energy == pytest.approx(0.5 * G12 * gamma**2 * 0.24 * 0.12 * t, rel=1e-5)


def test_orthotropic_explicit_force_matches_implicit_and_keeps_thickness():
    X, conn = grid(np.linspace(0, 4, 3), np.linspace(0, 2, 3), lambda x, y: (x, y, 0.1 * x * y))
    axes = np.random.default_rng(5).standard_normal((len(conn), 3))  # one direction per element
    model = Shell.orthotropic(X, conn, 0.3, *FABRIC, axis=axes)
    model.advance(0.05 * np.random.default_rng(4).standard_normal(model.n_dof))
    _, f = model.tangent_and_force()
    assert np.allclose(model.internal_force(), f, rtol=1e-12, atol=1e-12)
    model.accept()
    assert np.allclose(model.h, 0.3)
    with pytest.raises(ValueError):
        Shell(X, conn, 0.3, 1000.0, 0.3, 5.0, 10.0, 0.5, orthotropic=FABRIC)


@pytest.mark.parametrize("axis, modulus, nu", [(None, FABRIC[0], FABRIC[2]),
                                               ((0.0, 1.0, 0.0), FABRIC[1], FABRIC[2] * FABRIC[1] / FABRIC[0])])
def test_orthotropic_strip_finite_stretch_newton(axis, modulus, nu):
    """Implicit (Newton) path at finite strain, uniaxial along a material axis: Kirchhoff
    stress E ln(lambda) on the Hencky strain, lateral log strain -nu ln(lambda), thickness
    kept at h0, hence F = E ln(lambda) W t / lambda."""
    L, W, t, U = 10.0, 2.0, 0.3, 3.0
    X, conn = grid(np.linspace(0, L, 5), np.linspace(0, W, 3))
    model = Shell.orthotropic(X, conn, t, *FABRIC, axis=axis)
    left, right = np.flatnonzero(X[:, 0] == 0), np.flatnonzero(X[:, 0] == L)
    fixed = np.concatenate([dofs(left, [0]), dofs(left[0], [1]),
                            dofs(np.arange(len(X)), [2, 3, 4, 5])])
    model.hold(fixed)
    hist = solve(model, fixed, dofs(right, [0]), [U] * len(right), controls=Controls(n_steps=6))
    top = np.flatnonzero(X[:, 1] == W)
    for lam, force in zip(hist.lam[1:], hist.reaction[1:]):
        stretch = 1 + lam * U / L
        assert force == pytest.approx(modulus * np.log(stretch) * W * t / stretch, rel=1e-4)
    assert model.x[top, 1].mean() == pytest.approx(W * np.exp(-nu * np.log(1 + U / L)), rel=1e-6)
    assert np.allclose(model.h, t)
