#!/usr/bin/env python
"""§4.2.2 / Fig. 8: three Franka Panda arms reach a larger, displaced and tilted cooperative circle.

The ``fig08`` preset of ``experiments/reaching.py`` (the same run as
``python experiments/reaching.py --figure fig08``; see that script for the shared setup).

System ``three_franka`` (21 joints; bases 120° apart on a 0.8 m circle, facing the centre),
cooperative circle through the three TCPs (Eq 14), starting at rest at the nominal q0
(initial circle: centre (0, 0, 0.487) m, radius 0.493 m, normal +z).

Target (defaults, see the options): the initial circle moved by the world similarity

    S = T(t) · [R(25° about +x) · D(1.25)] about the TCPs' centroid (≈ the centre),   t = (0.10, −0.05, 0.10) m,

i.e. centre (0.10, −0.05, 0.587) m, radius 0.616 m, normal tilted 25° from +z toward −y.
The target versor is its canonical similarity ``V_Sd = V_S(X_u, X_d)`` (Eq 28).  A
Gauss–Newton IK solve checks that it is reachable.  The target circle is larger, so the
dilation command (e0∞) is non-zero — the paper's point about Fig. 8b; its integral over the
horizon equals log(r_n / r_0) = log 1.25 (metrics ``integrated_dilation_command``).

Solvers:

* iLQR on Eq 53–57 (``coop_ga.control.ilqr_reach``, its defaults): double integrator
  x = [q; q̇], u = q̈, 250 knots × Δt = 0.01 s = 2.5 s (the paper's Δt = 0.001 s contradicts
  its 2.5 s horizon: 250 × 0.001 s = 0.25 s), R = 1e-3 I, Q = 1e5 I, terminal rest term
  1e2 ‖q̇_n‖², tol 1e-5; ``--fast``: 100 knots × 0.025 s (the same 2.5 s);
* differential IK for comparison (``coop_ga.control.diff_ik_reach``): commanded body
  velocity ``B = gain · log(Ṽ_Sc V_Sd)`` over the same horizon (gain 10 /s, same Δt).

Writes to ``--out``: ``metrics.json`` (top level ``converged``, ``terminal_error``,
``iterations``, ``max_limit_violation`` [rad], the ``ilqr_*`` and ``diffik_*`` keys and the
``gallery`` block), ``trajectory.npz``, ``timing.json`` (wall-clock times, not committed),
``scene.png`` (the arms at the initial (light) and final (grey) configuration, the initial
(green), intermediate, final (turquoise) and target (black, dashed) circles and the TCP paths)
and ``bivector.png`` (the bivector command ``J^G(q_t) q̇_t`` — the body velocity of the
cooperative circle — the error bivector ``log(Ṽ_Sc(q_t) V_Sd)``, and the error norm of iLQR
and differential IK over the horizon).

    python experiments/circle_reaching.py --out results/circle_reaching
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

from coop_ga.harness import Experiment

FIGURE = "fig08"
_MODULE = "coop_ga_experiments_reaching"


def _reaching() -> ModuleType:
    """``experiments/reaching.py`` as a module (the scripts are not a package)."""
    mod = sys.modules.get(_MODULE)
    if mod is None:
        spec = importlib.util.spec_from_file_location(_MODULE, Path(__file__).with_name("reaching.py"))
        assert spec is not None and spec.loader is not None
        mod = importlib.util.module_from_spec(spec)
        sys.modules[_MODULE] = mod  # its dataclasses look their module up here
        spec.loader.exec_module(mod)
    return mod


def main(argv: list[str] | None = None) -> int:
    reaching = _reaching()
    exp = Experiment(__file__, __doc__, seed=0)
    reaching.add_options(exp, figure=FIGURE)
    args = exp.parse(argv)
    return int(reaching.run(exp, args, FIGURE))


if __name__ == "__main__":
    sys.exit(main())
