"""Replay a run's log in its model with MuJoCo alone.

A run folder (:meth:`coop_ga.sim.SimulationLog.save`) holds

=================  ==========================================================================
``model.xml``      the exact MuJoCo model of the run (``MjSpec.to_xml`` at full precision, meshes
                   inline; checked to reload bit for bit before it is written)
``log.npz``        ``time`` (T,) [s]; ``qpos`` (T, model.nq); ``qvel`` (T, model.nv): the state at
                   the start of each physics step; ``ctrl`` (T, model.nu): the controls applied
                   during that step (the last row is the final state; its ctrl is not applied).
                   With disturbances also ``xfrc_bodies`` (m,) body ids and ``xfrc`` (T, m, 6):
                   the ``data.xfrc_applied`` rows of those bodies during each step.
                   With mocap bodies (a recorded human hand) also ``mocap_pos`` (T, nmocap, 3)
                   and ``mocap_quat`` (T, nmocap, 4): their poses during each step, set like
                   ``ctrl`` (the hand is an input of the run, not part of its state).
                   A thinned log (long walks) keeps ``ctrl`` (and ``xfrc``) at every step and the
                   state at some steps only: ``state_rows`` (S,) the step index of each row of
                   ``time``, ``qpos`` and ``qvel`` (S rows; the first is step 0).  ``ctrl`` may be
                   float32 when every applied control is a float32 value (then it is exact)
``metrics.json``   ``log_version``, ``object_body`` (the first free object's body name), the maps
                   from the system's joint order to MuJoCo (``qpos_index``, ``qvel_index``,
                   ``actuator_index``), timestep, counts of saturated controls, …
=================  ==========================================================================

Replaying: load the model, set ``qpos[0]``, ``qvel[0]``, ``time[0]``, then for k = 0 … T − 2 set
``ctrl[k]`` (and ``xfrc``, ``mocap_pos``/``mocap_quat``), call ``mujoco.mj_step`` and compare with row k + 1 (a thinned log: with the
state row of step k + 1, where there is one).  MuJoCo is
deterministic on one thread, so the replay is bitwise (difference 0.0) on the machine that ran it.
"""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["replay"]


def replay(folder: str | Path, *, return_states: bool = False) -> Any:
    """Re-simulate ``folder/log.npz`` in ``folder/model.xml`` with MuJoCo alone (module docstring).

    Uses only ``mujoco`` and ``numpy``: a reader without coop_ga can run the same loop.

    Args:
        folder: a run folder written by :meth:`~coop_ga.sim.SimulationLog.save`.
        return_states: also return the replayed ``qpos`` (the rows of the log's ``qpos``).

    Returns:
        The largest |qpos difference| over the run (float), or ``(difference, qpos)``.
    """
    mujoco = importlib.import_module("mujoco")  # (typed Any: mujoco ships no type information)

    folder = Path(folder)
    model = mujoco.MjModel.from_xml_string((folder / "model.xml").read_text())
    log = np.load(folder / "log.npz")
    qpos, qvel, ctrl, time = log["qpos"], log["qvel"], log["ctrl"], log["time"]
    rows = log["state_rows"] if "state_rows" in log.files else np.arange(len(time))
    bodies = log["xfrc_bodies"] if "xfrc_bodies" in log.files else np.zeros(0, dtype=np.int64)
    xfrc = log["xfrc"] if "xfrc" in log.files else None
    mpos = log["mocap_pos"] if "mocap_pos" in log.files else None
    mquat = log["mocap_quat"] if "mocap_quat" in log.files else None
    data = mujoco.MjData(model)
    if mpos is not None and mquat is not None:
        data.mocap_pos[:], data.mocap_quat[:] = mpos[0], mquat[0]
    data.qpos[:] = qpos[0]
    data.qvel[:] = qvel[0]
    data.time = float(time[0])
    mujoco.mj_forward(model, data)  # as the simulation does before its first step
    out = np.empty_like(qpos)
    out[0] = data.qpos
    j = 1
    for k in range(len(ctrl) - 1):
        data.ctrl[:] = ctrl[k]
        if xfrc is not None and len(bodies):
            data.xfrc_applied[bodies] = xfrc[k]
        if mpos is not None and mquat is not None:
            data.mocap_pos[:], data.mocap_quat[:] = mpos[k], mquat[k]
        mujoco.mj_step(model, data)
        if j < len(rows) and rows[j] == k + 1:
            out[j] = data.qpos
            j += 1
    diff = float(np.max(np.abs(out - qpos), initial=0.0))
    return (diff, out) if return_states else diff
