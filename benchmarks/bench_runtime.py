"""Runtime overhead: ticks per second of a 101-node tree, bare py_trees vs armtree.run.

Both are measured in this run, alternating, best round of each (CPU time); armtree runs with
the run log and status-change tracking on. Goal: overhead <= 10 %.
Anchor (issue 2): bare py_trees 2.6 ticks a 101-node tree about 1,100 times per
second here (~8.8 us per node tick); its SnapshotVisitor alone adds about 14 %.
Usage: python benchmarks/bench_runtime.py [--ticks N] [--rounds R]
"""

import argparse

from armtree.cli.bench import runtime_benchmark


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ticks", type=int, default=1000, help="ticks per round")
    parser.add_argument("--rounds", type=int, default=10, help="alternating rounds")
    args = parser.parse_args()
    for churn in (False, True):
        for line in runtime_benchmark(args.ticks, args.rounds, churn=churn).lines():
            print(line)


if __name__ == "__main__":
    main()
