"""The Covered Dragon's equal-time comparison, kept under its old name:
`python benchmarks/covered_dragon.py reference|compare ...` is
`python benchmarks/equal_time.py reference|compare covered_dragon ...`."""
import sys

from equal_time import main

if __name__ == "__main__":
    sys.argv[2:2] = ["covered_dragon"]
    main()
