"""Two simulators agree: the paper's Figs. 5–6 impedance run on three_iiwa14 (no object), in MuJoCo and with
``pinocchio.aba`` (:func:`coop_ga.control.simulate_impedance`).

Same plant and same scheme: the scene has the Pinocchio model's inertias (the gate), no joint damping,
friction or armature (the iiwa URDF has none, as ``aba`` assumes), gravity from the model; MuJoCo's
``euler`` integrator is semi-implicit Euler (q̇ += Δt q̈; q += Δt q̇), the library's scheme, at the
same Δt = 1 ms; the same controller (``impedance_torque``, saturated at the effort limits) is called
at every step with MuJoCo's state.  Contacts stay enabled: nothing touches during the run (checked).
With ``implicitfast`` (the scene's default) the result is the same, since the only velocity-dependent
forces it treats implicitly (joint damping, actuator velocity gains) are zero here.  The difference is
round-off of two different dynamics algorithms (CRB + LDLᵀ vs ABA): ~1e-14 rad over 1 s.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("mujoco")

import coop_ga as cg
from coop_ga.control import ImpedanceOptions, impedance_torque, simulate_impedance
from coop_ga.sim import Simulation, build_scene

DURATION = 1.0
TOL = 1e-6  # [rad], the bar; measured ~1e-14


@pytest.fixture(scope="module")
def reference(load_system):
    """The library's run: (system, task, target, q_init, options, ImpedanceResult)."""
    s = load_system("three_iiwa14")
    task = cg.cooperative_task(s, "circle")
    Vd = task.similarity(s.q0)
    q_init = s.q0 + np.random.default_rng(0).uniform(-0.1, 0.1, s.nq)  # as experiments/impedance_three_iiwa.py
    opts = ImpedanceOptions(duration=DURATION, dt=1e-3)
    return s, task, Vd, q_init, opts, simulate_impedance(task, q_init, Vd, opts)


@pytest.mark.parametrize("integrator", ["euler", "implicitfast"])
def test_mujoco_and_pinocchio_aba_agree(integrator: str, reference) -> None:
    s, task, Vd, q_init, opts, ref = reference
    scene = build_scene(s, visuals=False, integrator=integrator)
    assert np.all(scene.model.dof_damping == 0) and np.all(scene.model.dof_armature == 0)
    ncon = []

    def controller(t, q, qd, sensors):
        ncon.append(sensors.data.ncon)
        return impedance_torque(task, q, qd, Vd, opts)

    log = Simulation(scene, controller, q=q_init).run(DURATION)
    diff = np.abs(log.q - ref.trajectory).max()
    moved = np.abs(ref.trajectory - ref.trajectory[0]).max()
    print(
        f"{integrator}: max |q_mujoco − q_aba| over {DURATION:g} s = {diff:.3e} rad (joints moved up to {moved:.3f} rad)"
    )
    assert log.q.shape == ref.trajectory.shape and max(ncon) == 0
    assert moved > 0.05  # the comparison is not of two robots at rest
    assert diff < TOL
    np.testing.assert_allclose(log.qd, ref.qd, rtol=0, atol=1e-9)
