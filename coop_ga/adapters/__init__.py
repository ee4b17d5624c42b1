"""Adapters: coop_ga's cooperative tasks inside other robotics libraries (optional extras, ``pip install coop_ga[adapters]``).

* :mod:`coop_ga.adapters.pink` — a ``pink.tasks.Task`` wrapping a coop_ga task (the cooperative similarity, the
  dual task space, …), solved by ``pink.solve_ik`` together with pink's own tasks, limits and barriers.
* :mod:`coop_ga.adapters.crocoddyl` — the cooperative similarity error as a ``crocoddyl.ResidualModelAbstract`` with
  its exact Jacobian, and the reach as a crocoddyl shooting problem for FDDP/BoxFDDP (``pip install coop_ga[crocoddyl]``:
  crocoddyl 3.2.1 with Pinocchio 4.0.0, in an environment of its own).

Each module imports its library on import; this package imports none of them.
"""
