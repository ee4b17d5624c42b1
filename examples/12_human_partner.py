"""A human partner (paper §5.5): the G1 and a human carry a bar; the human's hand is a measured point.

One end of the bar is the human's hand h(t), a point the controller cannot move: here a smooth **synthetic**
recording (a figure-eight of ±4 cm × ±3 cm rising 4 cm, period 4 s, sampled at 100 Hz — not a motion-capture
file).  The other end is the G1's right hand.  :class:`~coop_ga.control.tasks.PartnerPairTask` holds the point
pair (hand, robot hand) at its direction d* and length ℓ* (the bar's rotation and length) while the hand moves;
the robot's left hand holds its place (a :class:`~coop_ga.control.PositionTask`).  Differential IK through
:func:`~coop_ga.control.solve_step` inside the joint position and velocity limits, 1 s to settle on the still
hand, then two periods of motion; run for three gains α, with the measured point's motion treated

* as an unknown disturbance (feedback only: the robot lags the hand by about ‖ḣ‖/α), and
* with feed-forward of the measured hand velocity (``set_partner(h, velocity=ḣ)``, ḣ from the recording).

Prints and writes (``metrics.json``) the worst direction error [rad] and length error [m] while the hand moves,
per gain and mode, and ``errors.png`` (the errors over time for the middle gain).  Kinematic only: the physics
version (MuJoCo, a free bar held by the squeeze) is ``experiments/sim_human_partner.py``.

Run::

    python examples/12_human_partner.py --out /tmp/ex12
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

import coop_ga as cg
from coop_ga.control import Configuration, PositionTask, default_limits, solve_step
from coop_ga.control.tasks import PartnerPairTask

#: Files this example writes into --out (the examples' test checks them).
OUTPUTS = ("metrics.json", "errors.png")

DT = 0.01
SETTLE = 1.0  # [s] on the still hand before it moves
PERIOD = 4.0  # [s] of the hand's figure-eight
GAINS = (10.0, 20.0, 40.0)  # α [1/s]


def hand(t: float, h0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The synthetic recording: the hand's position (3,) [m] and velocity (3,) [m/s] at t [s] after it starts."""
    w = 2 * np.pi / PERIOD
    pos = h0 + np.array([0.04 * np.sin(w * t), 0.03 * np.sin(2 * w * t), 0.02 * (1 - np.cos(w * t))])
    vel = np.array([0.04 * w * np.cos(w * t), 0.06 * w * np.cos(2 * w * t), 0.02 * w * np.sin(w * t)])
    return pos, vel


def carry(system: cg.systems.System, model: cg.CooperativeTask, gain: float, feed_forward: bool, periods: int) -> dict:
    """One run: the direction [rad] and length [m] errors over time while the hand moves, within the limits."""
    q0 = np.asarray(system.q0, dtype=float)
    h0 = model.points(q0)[0] + np.array([0.05, -0.02, 0.03])  # the human takes the bar near the robot's left hand
    task = PartnerPairTask(model, 1, direction=(0.1, 1.0, 0.05), length=0.4, partner=h0, gain=gain)
    hold = PositionTask(0, model.points(q0)[0], max_speed=None)
    limits = default_limits(system.limits)
    cfg = Configuration(model, q0)
    n_settle, n_move = round(SETTLE / DT), round(periods * PERIOD / DT)
    angle, length, lo, hi = [], [], system.limits.lower, system.limits.upper
    within = True
    for k in range(n_settle + n_move):
        moving = k >= n_settle
        h, hd = hand((k - n_settle) * DT if moving else 0.0, h0)
        task.set_partner(h, hd if (feed_forward and moving) else None)
        if moving:
            e = task.error(cfg)
            angle.append(2 * np.arcsin(min(1.0, 0.5 * float(np.linalg.norm(e[:3])))))  # ‖d − d*‖ = 2 sin(θ/2)
            length.append(abs(float(e[3])))
        st = solve_step(cfg, [task, hold], limits, DT)
        cfg.update(cfg.q + DT * st.velocity, st.velocity)
        within = within and bool(np.all(cfg.q >= lo - 1e-9) and np.all(cfg.q <= hi + 1e-9))
    return {"angle": np.array(angle), "length": np.array(length), "within_limits": within}


def _plot(runs: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 2, figsize=(9, 3.2), dpi=80)
    for label, r in runs.items():
        t = np.arange(r["angle"].size) * DT
        ax[0].semilogy(t, np.maximum(r["angle"], 1e-9), label=label)
        ax[1].semilogy(t, np.maximum(r["length"], 1e-9) * 1e3, label=label)
    ax[0].set(xlabel="t [s] (hand moving)", ylabel="direction error [rad]")
    ax[1].set(xlabel="t [s] (hand moving)", ylabel="length error [mm]")
    ax[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    """Every gain and mode; returns 0 when all stay within the joint limits, feedback keeps the bar within 0.05 rad
    and 1 cm, and feed-forward cuts both worst errors at least five-fold."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path(tempfile.gettempdir()) / "coop_ga_examples" / "12")
    ap.add_argument("--fast", action="store_true", help="one period of the hand's motion instead of two")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)

    system = cg.systems.load("g1_arms")
    model = cg.cooperative_task(system, "point_pair")
    periods = 1 if args.fast else 2
    metrics: dict = {"system": "g1_arms", "hand": "synthetic figure-eight", "dt": DT, "periods": periods, "runs": []}
    ok, shown = True, {}
    for gain in GAINS:
        worst = {}
        for ff in (False, True):
            r = carry(system, model, gain, ff, periods)
            worst[ff] = (float(r["angle"].max()), float(r["length"].max()))
            metrics["runs"].append({"gain": gain, "feed_forward": ff, "max_direction_error_rad": worst[ff][0],
                                    "max_length_error_m": worst[ff][1], "within_limits": r["within_limits"]})  # fmt: skip
            ok = ok and r["within_limits"]
            if gain == GAINS[1]:
                shown[f"α={gain:g}" + (", feed-forward" if ff else ", feedback only")] = r
        print(f"α = {gain:4.0f}/s: feedback only {worst[False][0]:.1e} rad, {1e3 * worst[False][1]:.2f} mm; "
              f"with feed-forward {worst[True][0]:.1e} rad, {1e3 * worst[True][1]:.3f} mm")  # fmt: skip
        ok = ok and worst[False][0] < 0.05 and worst[False][1] < 0.01
        ok = ok and all(worst[True][i] < 0.2 * worst[False][i] for i in (0, 1))
    print(f"all runs within the joint limits: {all(r['within_limits'] for r in metrics['runs'])}")
    (args.out / "metrics.json").write_text(json.dumps(metrics, indent=2))
    _plot(shown, args.out / "errors.png")
    print(f"wrote {', '.join(OUTPUTS)} to {args.out}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
