"""An interactive browser viewer: teleoperate a cooperative task by its primitive, play any trajectory.

Built on `viser <https://viser.studio>`_ (``pip install 'coop_ga[viewer]'``): a web server in the Python
process, the scene drawn with three.js in any browser tab.

* :func:`serve` — ``python -m coop_ga.viewer three_franka circle``: the robots from their visual meshes,
  the cooperative primitive in the paper's palette, a transform gizmo at its centre (translation and
  rotation of the target similarity) and a scale slider (its dilation); the robots follow through the
  limit-aware differential IK and the paper's teleoperation mapping (§4.5, Figs. 20–21), with live
  read-outs (‖e‖, well-definedness, manipulability per bivector direction, active limits, warnings,
  the control rate).  The control logic is :class:`~coop_ga.viewer.session.TeleopSession`.
* :func:`play` — ``coop_ga.viewer.play(system, result.trajectory, primitives="circle")``; :func:`play_file`
  — ``python -m coop_ga.viewer --play results/reaching/trajectory.npz``: any experiment's NPZ or a
  physics log of :mod:`coop_ga.sim` (:func:`~coop_ga.viewer.recording.load_recording`), with a time
  slider, play/pause, speed and loop.

Layer: above :mod:`coop_ga.sim` (it reads its logs), below :mod:`coop_ga.sweep`.  viser is imported when a
server starts, so ``import coop_ga.viewer`` works without it.
"""

from .app import Viewer, play, play_file, play_recording, serve
from .recording import Recording, load_recording
from .session import Readout, TeleopSession

__all__ = [
    "Readout",
    "Recording",
    "TeleopSession",
    "Viewer",
    "load_recording",
    "play",
    "play_file",
    "play_recording",
    "serve",
]
