"""Targets for cooperative controllers: realisable similarities built from a task's current primitive."""

from __future__ import annotations

from typing import Any

from .. import validation
from ..geometry.groups import Similarity

__all__ = ["displaced_target"]


def displaced_target(
    task: Any,
    q: Any,
    *,
    translation: Any = (0.0, 0.0, 0.0),
    axis: Any = (1.0, 0.0, 0.0),
    angle: float = 0.0,
    scale: float = 1.0,
) -> Similarity:
    """A reachable-by-construction target: the cooperative primitive at ``q`` moved by a world similarity.

    ``S = T(translation) · [rotation by angle [rad] right-handed about axis (3,), then scaling
    by scale] about p̄``, with p̄ the centroid of the task's end points at q (world frame,
    metres).  The target primitive is ``X_d = S X_c(q) S̃`` and the returned target is
    ``V_Sd = V_S(X_u, X_d)`` (Eq 28, :meth:`CooperativeTask.target_from_primitive`) — the versor of
    X_d in the task's chart, so that ``e = log(Ṽ_Sc V_Sd)`` can vanish (``S · V_Sc(q)`` itself may differ from it
    by a roll about a circle's normal, which no configuration realises).

    Returns the target :class:`~coop_ga.Similarity`; its primitive is ``target.apply(task.unit)``.
    """
    qv = validation.configuration(q, task.nq, owner=f"task '{task.name}'")
    pbar = task.points(qv).mean(axis=0)
    Tp = Similarity.from_parts(translation=pbar)
    S = (
        Similarity.from_parts(translation=translation)
        @ Tp
        @ Similarity.from_parts(axis=axis, angle=angle, scale=scale)
        @ Tp.inverse()
    )
    return task.target_from_primitive(S.apply(task.primitive(qv)))
