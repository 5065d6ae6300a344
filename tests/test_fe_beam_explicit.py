"""Parallel explicit beam kernels against the assembled co-rotational beam."""
import numpy as np
import pytest

from harnesspipe.fe.elements.beam import (BeamMesh, FibreMaterial, FibreSection, assemble_beams,
                                          initial_frames, lobatto_points)
from harnesspipe.fe.elements.beam_explicit import (Beams, beam_forces, beam_lumped_mass,
                                                   beam_plastic_work, beam_stable_step)
from harnesspipe.fe.materials.fiber import disc_fibres
from harnesspipe.fe.rotation import rotate_nodes


def _two_wires(n_el=8, length=40.0):
    """Two straight wires along x (radii 0.7 and 0.6), 1 mm apart in y."""
    xs = np.linspace(0.0, length, n_el + 1)
    X = np.vstack([np.c_[xs, np.zeros_like(xs), np.zeros_like(xs)],
                   np.c_[xs, np.ones_like(xs), np.zeros_like(xs)]])
    c = np.c_[np.arange(n_el), np.arange(1, n_el + 1)]
    conn = np.vstack([c, c + n_el + 1]).astype(np.int64)
    return X, conn


def _deform(X, seed=3):
    rng = np.random.default_rng(seed)
    u = np.zeros_like(X)
    u[:, 1] = 0.4 * np.sin(X[:, 0] / 9.0)
    u[:, 2] = 0.2 * np.cos(X[:, 0] / 7.0)
    u[:, 0] = 0.05 * X[:, 0] / 40.0
    quat = np.zeros((X.shape[0], 4))
    quat[:, 0] = 1.0
    rotate_nodes(quat, rng.normal(scale=0.05, size=(X.shape[0], 3)))
    return u, quat


def test_parallel_forces_equal_assembled_beams_per_body():
    X, conn = _two_wires()
    R0 = initial_frames(X, conn)
    u, quat = _deform(X)
    xi, w = lobatto_points(3)
    secs = [disc_fibres(r, 3, 8) for r in (0.7, 0.6)]
    mats = np.array([[4528.0, 4.52, 1327.0, 0.9], [5641.0, 4.95, 850.0, 0.78]])
    GJ = np.array([80.0, 50.0])
    n_el = conn.shape[0]
    half = n_el // 2
    sec_id = np.repeat([0, 1], half).astype(np.int64)
    ng, nf = xi.size, secs[0][0].size
    hist = [np.zeros((n_el, ng, nf)) for _ in range(3)]   # eps_p, alpha, alpha^n (in place)
    f_el = np.zeros((n_el, 12))
    f_int = np.zeros((X.shape[0], 6))
    sec = [np.ascontiguousarray(np.stack([s[k] for s in secs])) for k in range(3)]
    beams = Beams(X, conn, R0, xi, w, *sec, GJ, sec_id, mats, sec_id.copy(), *hist, f_el)
    beam_forces(beams, X + u, quat, f_int, 2)
    for body in (0, 1):
        sl = slice(body * half, (body + 1) * half)
        h = np.zeros((2, half, ng, nf))                        # the trial history
        f = np.zeros(6 * X.shape[0])
        band = np.zeros((1, 1))
        assemble_beams(BeamMesh(X, conn[sl], R0[sl], xi, w), u, quat,
                       FibreSection(*secs[body], GJ[body]), FibreMaterial(*mats[body]), False,
                       np.zeros((2, half, ng, nf)), h, False, f, band, 0)
        nodes = np.unique(conn[sl])
        np.testing.assert_allclose(f_int[nodes].ravel(), f.reshape(-1, 6)[nodes].ravel(),
                                   rtol=1e-12, atol=1e-10)
        np.testing.assert_array_equal(hist[1][sl], h[1])        # new alpha
        np.testing.assert_allclose(hist[2][sl], h[1] ** mats[body, 3], rtol=1e-13)   # alpha^n
    assert np.abs(f_int).max() > 1.0            # the state is strained (yielded)
    assert hist[1].max() > 0.0
    W = beam_plastic_work(beams)
    assert W > 0.0


def test_lumped_mass_total_and_stable_step_bounds_a_free_vibration():
    E, rho, r, length, n_el = 4528.0, 25 * 4.34e-9, 0.7, 40.0, 8
    A, I = np.pi * r**2, np.pi * r**4 / 4
    xs = np.linspace(0.0, length, n_el + 1)
    X = np.c_[xs, np.zeros_like(xs), np.zeros_like(xs)]
    conn = np.c_[np.arange(n_el), np.arange(1, n_el + 1)].astype(np.int64)
    m = np.zeros((X.shape[0], 6))
    beam_lumped_mass(X, conn, np.full(n_el, A), np.full(n_el, I), np.full(n_el, rho), m)
    assert m[:, 0].sum() == pytest.approx(rho * A * length)
    l = np.full(n_el, length / n_el)
    dt_e = beam_stable_step(l, A, I, E, E / 2.78, rho).min()
    assert dt_e <= l[0] / np.sqrt(E / rho) * (1 + 1e-12)   # never above the bar limit l/c

    def run(dt, steps=3000):
        xi, w = lobatto_points(3)
        y, z, a = disc_fibres(r, 3, 8)
        sec = [np.ascontiguousarray(v[None, :]) for v in (y, z, a)]
        mats = np.array([[E, 1e9, 0.0, 1.0]])
        ids = np.zeros(n_el, dtype=np.int64)
        R0 = initial_frames(X, conn)
        hist = [np.zeros((n_el, 3, y.size)) for _ in range(3)]
        x = X.copy()
        quat = np.zeros((X.shape[0], 4))
        quat[:, 0] = 1.0
        rng = np.random.default_rng(0)
        v = rng.normal(scale=1.0, size=m.shape)        # all modes excited
        beams = Beams(X, conn, R0, xi, w, *sec, np.array([E / 2.78 * 2 * I]), ids, mats, ids,
                      *hist, np.zeros((n_el, 12)))
        f = np.zeros_like(m)
        for _ in range(steps):
            f[:] = 0.0
            beam_forces(beams, x, quat, f, 2)
            v -= dt * f / m
            x += dt * v[:, :3]
            rotate_nodes(quat, np.ascontiguousarray(dt * v[:, 3:]))
            if not np.all(np.isfinite(x)) or np.abs(x - X).max() > 1e3:
                return False
        return True

    assert run(0.9 * dt_e)
    assert not run(2.5 * dt_e)


def _random_chain_state(seed, n_wires=4, n_el=40, rot=0.6):
    """Wires of a bundle in a random large-rotation state with random committed history."""
    rng = np.random.default_rng(seed)
    xs = np.linspace(0.0, 30.0, n_el + 1)
    X, conn = [], []
    for w in range(n_wires):
        X.append(np.c_[xs, np.full_like(xs, 1.5 * w), np.zeros_like(xs)])
        c = np.c_[np.arange(n_el), np.arange(1, n_el + 1)] + w * (n_el + 1)
        conn.append(c)
    X = np.vstack(X)
    conn = np.vstack(conn).astype(np.int64)
    R0 = initial_frames(X, conn)
    # large rigid rotation of each wire + bending/stretching + large nodal spins
    x = X.copy()
    quat = np.zeros((X.shape[0], 4))
    quat[:, 0] = 1.0
    for w in range(n_wires):
        sl = slice(w * (n_el + 1), (w + 1) * (n_el + 1))
        spin = rng.normal(scale=1.2, size=3)
        q = np.zeros((1, 4))
        q[0, 0] = 1.0
        rotate_nodes(q, spin[None, :])
        from harnesspipe.fe.rotation import quat_to_matrix
        Rw = np.zeros((3, 3))
        quat_to_matrix(q[0], Rw)
        xl = X[sl] - X[sl].mean(axis=0)
        xl[:, 1] += 2.0 * np.sin(xl[:, 0] / 6.0)
        xl[:, 2] += 1.0 * np.cos(xl[:, 0] / 5.0)
        xl[:, 0] *= 1.0 + 0.01 * rng.normal()
        x[sl] = xl @ Rw.T + X[sl].mean(axis=0)
        quat[sl] = q[0]
    rotate_nodes(quat, rng.normal(scale=rot, size=(X.shape[0], 3)))
    return X, conn, R0, x, quat, rng


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_lean_forces_equal_element_response_at_large_rotations_with_yielding(seed):
    from harnesspipe.fe.elements.beam_explicit import beam_forces_reference
    X, conn, R0, x, quat, rng = _random_chain_state(seed)
    xi, w = lobatto_points(3)
    secs = [disc_fibres(r, 3, 4) for r in (0.7, 0.6)]
    sec = [np.ascontiguousarray(np.stack([s[k] for s in secs])) for k in range(3)]
    mats = np.array([[4528.0, 4.52, 1327.0, 0.9], [5641.0, 4.95, 850.0, 0.78],
                     [5641.0, 4.95, 850.0, 1.3]])
    GJ = np.array([80.0, 50.0])
    n_el = conn.shape[0]
    sec_id = rng.integers(0, 2, n_el).astype(np.int64)
    mat_id = rng.integers(0, 3, n_el).astype(np.int64)
    ng, nf = xi.size, sec[0].shape[1]
    alpha_c = np.where(rng.random((n_el, ng, nf)) < 0.5, rng.random((n_el, ng, nf)) * 5e-3, 0.0)
    eps_p_c = alpha_c * rng.choice([-1.0, 1.0], size=alpha_c.shape) * rng.random(alpha_c.shape)
    sa_c = alpha_c ** mats[mat_id, 3][:, None, None]           # the flow-stress history
    out = []
    for fun, nch in ((beam_forces, 2), (beam_forces_reference, 2), (beam_forces, 1)):
        f_el = np.zeros((n_el, 12))
        f = np.zeros((X.shape[0], 6))
        if fun is beam_forces:                      # the committed history, advanced in place
            h = [eps_p_c.copy(), alpha_c.copy(), sa_c.copy()]
            fun(Beams(X, conn, R0, xi, w, *sec, GJ, sec_id, mats, mat_id, *h, f_el), x, quat,
                f, nch)
        else:                                       # committed read, trial written
            h = [np.zeros((n_el, ng, nf)) for _ in range(3)]
            committed = Beams(X, conn, R0, xi, w, *sec, GJ, sec_id, mats, mat_id, eps_p_c,
                              alpha_c, sa_c, f_el)
            fun(committed, committed._replace(eps_p=h[0], alpha=h[1], sa_h=h[2]), x, quat, f, nch)
        out.append((f_el, f, h))
    (fe, f, h), (fe_r, f_r, h_r), (fe_1, f_1, h_1) = out
    scale = np.abs(fe_r).max(axis=1, keepdims=True)
    assert np.all(np.abs(fe - fe_r) <= 1e-12 * scale)          # per element, 1e-12 relative
    assert np.abs(f - f_r).max() <= 1e-12 * np.abs(f_r).max()
    for k in range(3):                                          # same return map, same strains
        np.testing.assert_allclose(h[k], h_r[k], rtol=1e-13, atol=1e-18)
    np.testing.assert_array_equal(fe_1, fe)                     # chunking does not matter
    assert (h[1] > alpha_c).sum() > 20                          # fibres yield in this step
    # the state has large local rotations (Ts^-1, eta terms matter)
    assert np.abs(f).max() > 1.0
