"""The replay's equilibrium kernels take shortcuts that change no figure: the energy that skips the search of a wall
sample clear of its segment is the full energy to the bit, and an equilibrium ends with every sample's segment as a
full evaluation finds it; the poses built for many chains at once are the chains built one by one."""
from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from bhr._run.motion import ordered_moves
from bhr._studies.physics import equilibrium as eq
from bhr._studies.physics.poses import chain_points as poses_chain_points


def _tube(bend: float, narrow: float) -> tuple[np.ndarray, np.ndarray]:
    """A centerline along +z that bends by ``bend`` rad per 10 mm, 1 mm apart, its radius 9 mm narrowing by
    ``narrow`` mm and widening again along it."""
    s = np.arange(0.0, 160.0, 1.0)
    th = bend * s / 10.0
    k = np.maximum(bend / 10.0, 1e-9)
    C = np.stack([(1.0 - np.cos(th)) / k, np.zeros_like(s), np.sin(th) / k], axis=1)
    return np.ascontiguousarray(C), 9.0 - narrow * np.sin(np.pi * s / 160.0)


@settings(max_examples=60, deadline=None)
@given(bend=st.floats(0.0, 0.4), narrow=st.floats(0.0, 4.0), seed=st.integers(0, 2**32 - 1),
       spread=st.floats(0.0, 0.6), shift=st.floats(0.0, 3.0))
def test_the_energy_that_skips_clear_samples_is_the_full_energy_and_finds_the_same_segments(bend, narrow, seed,
                                                                                            spread, shift):
    C, R = _tube(bend, narrow)
    rng = np.random.default_rng(seed)
    M, ns, L, radius = 16, 5, 5.0, 5.0
    base, d0, A0 = np.zeros(3), np.array([0.0, 0.0, 1.0]), np.eye(3)
    target = rng.uniform(-spread, spread, (M, 2))
    z = np.concatenate([[rng.uniform(0.0, 40.0)], target.reshape(-1)])
    pts = np.empty((M + 1, 3))
    eq.chain_points(z, base, d0, A0, L, pts)
    seg = np.zeros(M * ns, dtype=np.int64)
    eq.global_seg(C, np.repeat(0.5 * (pts[:-1] + pts[1:]), ns, axis=0), seg)
    z = z + rng.normal(0.0, 0.05, z.size) + np.concatenate([[shift], np.zeros(2 * M)])  # the robot moved on
    args = (z, target, 0.0, base, d0, A0, L, radius, ns, 0.12, np.full(M, 67.0), 20.0, 43.0, C, R, seg)
    out = {}
    for full in (True, False):
        ws = (np.zeros(z.size), np.zeros(M * ns), np.empty((M, 3, 3)), np.empty((M, 3, 3)), np.empty((M, 3)),
              np.zeros((M * ns, 3)), np.zeros((M * ns, 3)), np.zeros(M * ns))
        found = seg.copy()
        E = eq._energy(*args[:16], found, *ws, full)
        out[full] = (E, ws, found)
    (E1, w1, f1), (E0, w0, f0) = out[True], out[False]
    assert E0 == E1
    assert np.array_equal(w0[0], w1[0])  # the gradient
    assert np.array_equal(w0[1], w1[1])  # every sample's depth into the wall
    inside = w1[1] > 0.0
    assert np.array_equal(w0[5][inside], w1[5][inside]) and np.array_equal(w0[7][inside], w1[7][inside])
    assert np.array_equal(f0[inside], f1[inside])
    ends = seg.copy()
    eq._settle(C, R, ends, f0, w0[6], w0[1], radius)
    assert np.array_equal(ends, f1)  # the next equilibrium searches from where a full evaluation found them


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 6), m=st.integers(1, 40))
def test_chains_built_together_are_the_chains_built_one_by_one(seed, n, m):
    rng = np.random.default_rng(seed)
    tilts = rng.uniform(-0.6, 0.6, (n, m, 2))
    tilts[rng.uniform(size=(n, m)) < 0.3] = 0.0  # joints at rest
    base = rng.normal(0.0, 10.0, (n, 3))
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    frame = q * np.sign(np.linalg.det(q))  # rows x y z, a rotation
    together = poses_chain_points(base, frame, tilts, 5.0)
    for i in range(n):
        one = np.empty((m + 1, 3))
        eq.chain_points(np.concatenate([[0.0], tilts[i].reshape(-1)]), base[i], frame[2], frame.T.copy(), 5.0, one)
        assert np.abs(together[i] - one).max() < 1e-9
        assert np.allclose(np.linalg.norm(np.diff(together[i], axis=0), axis=1), 5.0, atol=1e-9, rtol=0.0)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), k=st.integers(1, 30), j=st.integers(1, 12))
def test_the_largest_joint_move_is_numpys_to_the_bit(seed, k, j):
    """The poses in time order ``order`` (the refinement appends poses out of order), not gathered."""
    rng = np.random.default_rng(seed)
    first, pts = rng.normal(0.0, 3.0, (j, 3)), rng.normal(0.0, 3.0, (k, j, 3))
    order = rng.permutation(k)
    out = np.empty(k)
    ordered_moves(first, pts, order, out)
    full = np.concatenate([first[None], pts[order]])
    assert np.array_equal(out, np.max(np.linalg.norm(np.diff(full, axis=0), axis=2), axis=1))
    assert math.isfinite(out.sum())


def _winding_tube(rng: np.random.Generator, length_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """A centerline in the x-z plane whose heading swings ±(0.2-0.6 rad per 10 mm) over a wavelength of
    80-300 mm, 1 mm apart; its radius 8-14 mm, narrowing by up to 5 mm in the middle."""
    s = np.arange(0.0, length_mm, 1.0)
    rate, wave = rng.uniform(0.2, 0.6), rng.uniform(80.0, 300.0)
    th = rate * np.sin(2.0 * np.pi * s / wave) * wave / (2.0 * np.pi) / 10.0
    d = np.stack([np.sin(th), np.zeros_like(s), np.cos(th)], axis=1)
    C = np.ascontiguousarray(np.cumsum(d, axis=0) - d[0])
    return C, rng.uniform(8.0, 14.0) - rng.uniform(0.0, 5.0) * np.sin(np.pi * s / length_mm) ** 2


def test_a_long_robot_pressed_into_the_wall_reaches_its_equilibrium_when_one_code_changes():
    # 100 modules of 5 mm, half their joints coded ±25° at random, in a winding tube they press into from the
    # start. From each one's equilibrium, one joint's code changes and the feeder moves 2 mm on, as from one step
    # of a run to the next. The chain's Newton step went uphill in its rounding there and the solver stopped at
    # once (none of these reached, from the same starts); damped, the step goes down
    M, ns, L, radius, a = 100, 5, 5.0, 5.0, math.radians(25.0)
    base, d0, A0 = np.zeros(3), np.array([0.0, 0.0, 1.0]), np.eye(3)
    loaded = reached = 0
    for seed in range(12):
        rng = np.random.default_rng(seed)
        C, R = _winding_tube(rng, M * L + 200.0)
        target = rng.choice([-a, 0.0, a], (M, 2), p=[0.15, 0.7, 0.15]) * (rng.uniform(size=(M, 1)) < 0.5)
        z = np.concatenate([[rng.uniform(0.0, 40.0)], np.zeros(2 * M)])
        pts = np.empty((M + 1, 3))
        eq.chain_points(z, base, d0, A0, L, pts)
        seg = np.zeros(M * ns, dtype=np.int64)
        eq.global_seg(C, np.repeat(0.5 * (pts[:-1] + pts[1:]), ns, axis=0), seg)
        pen = np.zeros(M * ns)
        walls = (0.1192, np.full(M, 67.4), 20.0, 43.1, C, R)
        x = z[0]
        if eq._equilibrium(z, target, x, base, d0, A0, L, radius, ns, *walls, seg, pen, eq.GTOL, eq.STALL_FORCE_N,
                           M * L, eq.MAX_ITERATIONS) > eq.MAX_ITERATIONS or not pen.any():
            continue
        loaded += 1
        target[rng.integers(0, M)] = rng.choice([-a, 0.0, a], 2)
        it = eq._equilibrium(z, target, x + 2.0, base, d0, A0, L, radius, ns, *walls, seg, pen, eq.GTOL,
                             eq.STALL_FORCE_N, M * L, eq.MAX_ITERATIONS)
        reached += it <= eq.MAX_ITERATIONS
    assert loaded >= 8 and reached == loaded, (reached, loaded)
