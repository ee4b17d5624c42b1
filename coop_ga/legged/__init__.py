"""Layer 8: legged robots — the hexapod's legs, terrain and contact, the stance feet as a cooperative
primitive, body posture control through it, gaits and walking.

* :mod:`~coop_ga.legged.legs` — per-leg motor FK, closed-form and DLS IK, vectorised over legs and batches;
* :mod:`~coop_ga.legged.terrain` — terrains as sets of CGA planes, contact by point–plane incidence;
* :mod:`~coop_ga.legged.stance` — the stance primitive (sphere / plane / circle, LSQ fits for more feet);
* :mod:`~coop_ga.legged.body`, :mod:`~coop_ga.legged.posture` — the floating body, posture control;
* :mod:`~coop_ga.legged.gait`, :mod:`~coop_ga.legged.walk` — phase-table gaits and walking.
"""
