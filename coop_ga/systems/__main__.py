"""``python -m coop_ga.systems``: list the registered systems with their DOF and end points."""

from . import load, names


def main() -> None:
    print(f"{'system':<18} {'DOF':>4}  end points")
    for n in names():
        s = load(n)
        print(f"{n:<18} {s.nq:>4}  {', '.join(s.end_frames)}")


if __name__ == "__main__":
    main()
