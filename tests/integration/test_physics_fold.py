"""The implicit damping folded into the mass matrix (bhr.studies.physics._Stepper) is MuJoCo's Euler step.

MuJoCo's Euler with implicit damping solves (M + h D) qacc = f (f with the damping's -D qvel); a mass matrix of
M + h D (armature + h D) with the damping explicit solves the same system. Checked on small chains of hinges held by
springs and dampers beside a damped slide body (a "simple" body, whose mass matrix MuJoCo copies from dof_M0), in
free motion, over random masses, stiffnesses, dampings and time steps (w h < 2); and a contact unfolds it (MuJoCo's own
implicit damping at that time step).
"""
from __future__ import annotations

import mujoco
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from bhr.studies.physics import _Stepper


def _model(links: int, mass: float, k: float, zeta: float, h: float, floor: bool = False) -> mujoco.MjModel:
    w = (k / mass) ** 0.5
    b = 2 * zeta * (k * mass) ** 0.5
    body = ""
    for i in range(links):
        body += (f'<body pos="0 0 {0.1 if i else 0}"><joint type="hinge" axis="{i % 2} {1 - i % 2} 0" '
                 f'stiffness="{k * 0.01}" damping="{b * 0.01}" armature="{mass * 0.01}"/>'
                 f'<geom type="capsule" fromto="0 0 0 0 0 0.1" size="0.01" mass="{mass}" contype="0" conaffinity="0"/>')
    body += "</body>" * links
    plane = '<geom type="plane" size="1 1 0.1" pos="0 0 0.175"/>' if floor else ""
    xml = f"""<mujoco><option timestep="{h}" gravity="0 0 {-9.81 if floor else 0}" integrator="Euler"/>
      <worldbody>{plane}<body pos="0.3 0 0.2"><joint type="slide" axis="0 0 1" stiffness="{k}" damping="{b}"/>
        <joint type="slide" axis="1 0 0" stiffness="{k}" damping="{b}"/>
        <geom type="sphere" size="0.02" mass="{mass}"/></body>
      {body}</worldbody></mujoco>"""
    m = mujoco.MjModel.from_xml_string(xml)
    assert w > 0
    return m


def _run(m: mujoco.MjModel, folded: bool, steps: int, q0: np.ndarray) -> tuple[np.ndarray, _Stepper]:
    d = mujoco.MjData(m)
    d.qpos[:] = q0
    step = _Stepper(mujoco, m, d, folded)
    out = []
    for _ in range(steps):
        step()
        out.append(np.concatenate([d.qpos, d.qvel]))
    return np.array(out), step


@settings(max_examples=40, deadline=None)
@given(links=st.integers(1, 6), mass=st.floats(0.001, 1.0), k=st.floats(1.0, 1e4), zeta=st.floats(0.2, 3.0),
       wh=st.floats(0.01, 1.9), seed=st.integers(0, 2**31 - 1))
def test_folded_damping_steps_as_mujocos_implicit_damping(links, mass, k, zeta, wh, seed):
    """Time steps up to 1.9 / w (the replay's longest is 1.96 / w), where the explicit spring is stable."""
    h = wh / (k / mass) ** 0.5
    q0 = np.random.default_rng(seed).uniform(-0.3, 0.3, size=links + 2)
    ref, _ = _run(_model(links, mass, k, zeta, h), False, 200, q0)
    m = _model(links, mass, k, zeta, h)
    got, step = _run(m, True, 200, q0)
    assert step.unfolded == 0 and step.folded  # never a constraint here: folded at every time step
    scale = np.abs(ref).max(axis=0) + 1e-12
    assert np.all(np.abs(got - ref) <= 1e-9 * scale + 1e-12)
    # the slide body is simple (its mass matrix is dof_M0's): folding the armature alone would leave it explicit
    assert m.dof_simplenum[0] > 0


def test_a_contact_unfolds_the_damping_for_that_time_step():
    """A ball on its spring dropped onto a floor above the spring's rest: the time steps with a contact are MuJoCo's
    own (undone and stepped again), so the whole fall and bounce is the implicit-damping replay's to rounding."""
    q0 = np.array([0.05, 0.0, 0.2, -0.1])
    ref, _ = _run(_model(2, 0.05, 50.0, 1.0, 2e-3, floor=True), False, 600, q0)
    got, step = _run(_model(2, 0.05, 50.0, 1.0, 2e-3, floor=True), True, 600, q0)
    assert step.redone >= 1 and 0 < step.unfolded < 600
    assert np.abs(got - ref).max() <= 1e-9
