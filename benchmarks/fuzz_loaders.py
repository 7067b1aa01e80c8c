"""Fuzz every loader many times (tests/fuzz_harness.py) and count the outcomes: loaded,
refused with one clear LiftError, or escaped (any other exception, or a LiftError the loader
marked as unforeseen). Prints a table; exits 1 if anything escaped, after showing the first
input that did (saved under --out).

    python benchmarks/fuzz_loaders.py [--cases 2000] [--seed 0] [--out out/fuzz]
"""
from __future__ import annotations

import argparse
import random
import sys
import tempfile
import time
import traceback
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from fuzz_harness import LOADERS, check_input, mutate, prepare  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cases", type=int, default=2000, help="inputs per loader")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default="out/fuzz", help="where escaping inputs are saved")
    parser.add_argument("--only", help="fuzz only the loader whose name contains this")
    args = parser.parse_args()
    rows, escaped_any = [], False
    for loader in LOADERS:
        if args.only and args.only.lower() not in loader.name.lower():
            continue
        rng = random.Random(f"{args.seed}:{loader.name}")
        counts = {"loaded": 0, "refused": 0, "refused, no line": 0, "escaped": 0}
        start = time.perf_counter()
        with tempfile.TemporaryDirectory() as tmp:
            path = prepare(loader, Path(tmp))
            for case in range(args.cases):
                data = mutate(rng.choice(loader.seeds).read_bytes(), rng)
                try:
                    counts[check_input(loader, data, path)] += 1
                except Exception:  # noqa: BLE001 - counting exactly these
                    counts["escaped"] += 1
                    out = Path(args.out)
                    out.mkdir(parents=True, exist_ok=True)
                    saved = out / f"{loader.name.replace(' ', '_')}-{case}{Path(loader.filename).suffix}"
                    saved.write_bytes(data)
                    if counts["escaped"] <= 3:
                        print(f"--- {loader.name}: escaped, input saved to {saved}", file=sys.stderr)
                        traceback.print_exc(limit=4)
        rows.append((loader.name, args.cases, counts, time.perf_counter() - start))
        escaped_any |= counts["escaped"] > 0
    print("| loader | inputs | loaded | refused: file:line | refused: file only | escaped | seconds |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    for name, n, c, seconds in rows:
        print(f"| {name} | {n} | {c['loaded']} | {c['refused']} | {c['refused, no line']} | {c['escaped']} "
              f"| {seconds:.0f} |")
    return 1 if escaped_any else 0


if __name__ == "__main__":
    sys.exit(main())
