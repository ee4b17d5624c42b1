"""Adapters: coop_ga's cooperative tasks inside other robotics libraries (optional extras, ``pip install coop_ga[adapters]``).

* :mod:`coop_ga.adapters.pink` — a ``pink.tasks.Task`` wrapping a coop_ga task (the cooperative similarity, the
  dual task space, …), solved by ``pink.solve_ik`` together with pink's own tasks, limits and barriers.

Each module imports its library on import; this package imports none of them.
"""
