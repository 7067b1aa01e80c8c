"""Fuzz every loader many times (tests/fuzz_harness.py TARGETS, inputs from
tests/fuzz_strategies.py) and count the outcomes: loaded, refused with file:line, refused
naming the file only, and escaped, by kind (an exception that is not a LiftError, a LiftError
marked internal or naming no file, a non-finite or negative value reaching the GPU, a hang,
more than 1 GiB, text printed by a library, a plugin file from outside its folder).

A loader's cases are split into shards of --shard-size (each a hypothesis run of its own
seed), and each shard runs in a worker process of its own, which reports every case on a pipe; a worker silent for --stall seconds (a hang the harness's timers cannot
interrupt, inside a C library) or one that dies (a crash) is counted as one escape, its input
kept, and a new worker goes on with the remaining cases. Escaping inputs are saved under
--out (the first few of each kind and message). Prints a table, writes it with the escapes
to --results (markdown and JSON) after every shard, exits 1 if anything escaped. --resume
runs only the shards that the results file does not hold yet: a run cut short (a time limit,
Ctrl-C) goes on where it stopped, on this machine or another.

    nice -n 19 python benchmarks/fuzz_loaders.py [--cases 10000] [--seed 0] [--only NAME] [--jobs 2] [--resume]
    python benchmarks/fuzz_loaders.py --replay out/fuzz/FOLDER...   # saved inputs again
"""
from __future__ import annotations

import argparse
import json
import os
import re
import select
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from collections import Counter
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

RESULTS = ROOT / "benchmarks" / "results" / "fuzz_loaders"
KEEP_PER_SIGNATURE = 3


def signature(target: str, kind: str, message: str) -> str:
    """An escape's message without its paths and numbers: escapes of one cause share it."""
    text = re.sub(r"/\S*?/case/", "", message)
    text = re.sub(r"(/[\w.-]+)+", "PATH", text)
    text = re.sub(r"-?\d[\d.e+-]*", "N", text)
    return f"{target} | {kind} | {text[:160]}"


# ---- the worker ---------------------------------------------------------------------------

def worker(target_name: str, cases: int, seed: int, root: Path, out: Path) -> None:
    """Run `cases` inputs of one target, one JSON line a case on stdout."""
    from hypothesis import HealthCheck, Phase, given, settings
    from hypothesis import seed as hypothesis_seed

    from fuzz_harness import BY_NAME, Escape, check_case, save_case

    target = BY_NAME[target_name]
    emit = os.fdopen(os.dup(1), "w", buffering=1)  # the pipe to the parent
    os.dup2(os.open(os.devnull, os.O_WRONLY), 1)  # so that nothing else written to stdout reaches it
    kept: Counter = Counter()
    number = [0]

    @hypothesis_seed(seed)
    @settings(max_examples=cases, database=None, deadline=None, phases=[Phase.generate],
              suppress_health_check=list(HealthCheck))
    @given(case=target.strategy())
    def run(case):
        number[0] += 1
        emit.write(json.dumps({"start": number[0], "how": case.how[:300]}) + "\n")
        try:
            outcome = check_case(target, case, root)
            record = {"outcome": outcome.kind, "cpu": round(outcome.seconds, 4),
                      "numpy_warnings": outcome.numpy_warnings, "warned": outcome.warned}
        except Escape as escape:
            sig = signature(target_name, escape.kind, escape.message)
            record = {"outcome": "escaped", "kind": escape.kind, "message": escape.message,
                      "signature": sig, "how": case.how[:300]}
            kept[sig] += 1
            if kept[sig] <= KEEP_PER_SIGNATURE:
                record["saved"] = str(save_case(case, out / f"{_slug(target_name)}-{seed}-{number[0]}", target))
        emit.write(json.dumps(record) + "\n")

    try:
        run()
    except Exception:  # noqa: BLE001 - the fuzzer's own failure (a strategy), not the loader's
        import traceback
        emit.write(json.dumps({"fuzzer_error": traceback.format_exc(limit=-3)[-600:]}) + "\n")
        raise SystemExit(3)
    emit.write(json.dumps({"done": number[0]}) + "\n")


def _slug(name: str) -> str:
    return re.sub(r"[^a-z0-9]+", "_", name.lower()).strip("_")


# ---- the parent ---------------------------------------------------------------------------

def fuzz_target(name: str, cases: int, seed: int, out: Path, stall: float) -> dict:
    counts = Counter()
    escapes: dict[str, dict] = {}
    cpu_max, numpy_warned, warned = 0.0, 0, 0
    slowest = ""
    start = time.perf_counter()
    done, restarts = 0, 0
    fuzzer_errors: list[str] = []
    while done < cases and len(fuzzer_errors) < 5:
        with tempfile.TemporaryDirectory(prefix="lift-gl-fuzz-") as tmp:
            root = Path(tmp) / "root"
            command = [sys.executable, __file__, "--worker", name, "--cases", str(cases - done),
                       "--seed", str(seed + 1000 * restarts), "--root", str(root), "--out", str(out)]
            env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
            proc = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, env=env, text=True,
                                    preexec_fn=_die_with_parent)
            current = None
            finished = False
            while True:
                ready, _, _ = select.select([proc.stdout], [], [], stall)
                if not ready:  # silent: a hang no timer could interrupt
                    proc.kill()
                    proc.wait()
                    _lost(current, "hang", f"no answer in {stall:g} s (killed)", name, root, out, seed, restarts,
                          counts, escapes)
                    done += 1
                    break
                line = proc.stdout.readline()
                if not line:  # the worker ended
                    proc.wait()
                    if current is not None:  # during a case: the loader crashed it
                        _lost(current, "crash", f"the worker died (exit {proc.returncode})", name, root, out, seed,
                              restarts, counts, escapes)
                        done += 1
                    elif not finished and not fuzzer_errors:
                        raise RuntimeError(f"the {name} worker failed to start (exit {proc.returncode})")
                    break
                if line.startswith('{"fuzzer_error"'):
                    fuzzer_errors.append(json.loads(line)["fuzzer_error"])
                    print(f"{name}: the fuzzer's own error, a new worker goes on:\n{fuzzer_errors[-1]}",
                          file=sys.stderr)
                    continue
                try:
                    record = json.loads(line)
                except ValueError:
                    continue  # not the worker's line
                if "start" in record:
                    current = record
                    continue
                if "done" in record:
                    finished = True
                    continue
                how = (current or {}).get("how", "")
                current = None
                done += 1
                counts[record["outcome"]] += 1
                if record["outcome"] == "escaped":
                    entry = escapes.setdefault(record["signature"], {"count": 0, "kind": record["kind"],
                                                                     "message": record["message"],
                                                                     "how": record["how"], "saved": None})
                    entry["count"] += 1
                    entry["saved"] = entry["saved"] or record.get("saved")
                else:
                    numpy_warned += record["numpy_warnings"] > 0
                    warned += bool(record["warned"])
                    if record["cpu"] > cpu_max:
                        cpu_max, slowest = record["cpu"], how
                if done % 500 == 0:
                    print(f"{name}: {done}/{cases}, escaped {counts['escaped']}", file=sys.stderr, flush=True)
        if finished:
            break  # all asked for were run (or hypothesis ran out of distinct inputs)
        restarts += 1
    print(file=sys.stderr)
    return {"target": name, "cases": done, "loaded": counts["loaded"], "refused": counts["refused"],
            "refused_no_line": counts["refused, no line"], "escaped": counts["escaped"],
            "warned": warned, "numpy_warnings": numpy_warned, "max_cpu_s": round(cpu_max, 3), "slowest": slowest,
            "seconds": round(time.perf_counter() - start, 1), "restarts": restarts, "fuzzer_errors": fuzzer_errors,
            "escapes": sorted(escapes.values(), key=lambda e: -e["count"]),
            "signatures": {sig: e["count"] for sig, e in escapes.items()}}


def _die_with_parent() -> None:
    """In the worker, before it starts: Linux kills it when this process ends."""
    import ctypes
    import signal
    try:
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except OSError:
        pass


def _lost(current, kind, message, name, root, out, seed, restarts, counts, escapes):
    """A case the worker never answered: keep its folder (the input is still on disk)."""
    how = (current or {}).get("how", "")
    saved = out / f"{_slug(name)}-{seed}-r{restarts}-{kind}"
    if (root / "case").exists() and not saved.exists():
        shutil.copytree(root / "case", saved, symlinks=True)
    sig = signature(name, kind, message)
    entry = escapes.setdefault(sig, {"count": 0, "kind": kind, "message": message, "how": how, "saved": str(saved)})
    entry["count"] += 1
    counts["escaped"] += 1


SHARD_SEED_STRIDE = 1_000_003  # shards' seeds far apart from a worker's restarts (seed + 1000 * restarts)


def shard_plan(cases: int, size: int) -> list[int]:
    """The cases of each shard: `cases` split into shards of `size`, the last one smaller."""
    return [min(size, cases - start) for start in range(0, cases, size)]


def merge_rows(name: str, rows: list[dict]) -> dict:
    """One loader's row from its shards' rows: counts summed, escapes merged by signature."""
    merged = {"target": name, "slowest": "", "fuzzer_errors": []}
    for key in ("cases", "loaded", "refused", "refused_no_line", "escaped", "warned", "numpy_warnings", "restarts"):
        merged[key] = sum(r[key] for r in rows)
    merged["seconds"] = round(sum(r["seconds"] for r in rows), 1)  # worker time, summed over shards
    slowest = max(rows, key=lambda r: r["max_cpu_s"], default=None)
    merged["max_cpu_s"] = slowest["max_cpu_s"] if slowest else 0.0
    merged["slowest"] = slowest["slowest"] if slowest else ""
    escapes: dict[str, dict] = {}
    for r in rows:
        merged["fuzzer_errors"] += r["fuzzer_errors"]
        for e in r["escapes"]:
            sig = signature(name, e["kind"], e["message"])
            kept = escapes.setdefault(sig, dict(e, count=0))
            kept["count"] += e["count"]
            kept["saved"] = kept["saved"] or e["saved"]
    merged["escapes"] = sorted(escapes.values(), key=lambda e: -e["count"])
    merged["signatures"] = {sig: e["count"] for sig, e in escapes.items()}
    return merged


def table(rows) -> str:
    lines = ["| loader | inputs | loaded | refused: file:line | refused: file only | escaped | loaded with a warning "
             "| numpy warnings | slowest case (CPU s) | seconds |",
             "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for r in rows:
        lines.append(f"| {r['target']} | {r['cases']} | {r['loaded']} | {r['refused']} | {r['refused_no_line']} "
                     f"| {r['escaped']} | {r['warned']} | {r['numpy_warnings']} | {r['max_cpu_s']:.2f} "
                     f"| {r['seconds']:.0f} |")
    return "\n".join(lines)


def escapes_text(rows) -> str:
    lines = []
    for r in rows:
        for e in r["escapes"]:
            message = re.sub(r"/\S*?/case/", "CASE/", e["message"])  # the run's temporary folder
            saved = e["saved"] and os.path.relpath(e["saved"], ROOT)   # not this machine's path
            lines.append(f"- {r['target']}, {e['kind']} ({e['count']}): {message[:240]} — input: {e['how'][:160]}"
                         + (f" (saved: {saved})" if saved else ""))
    return "\n".join(lines) or "None."


def replay(folders: list[Path]) -> int:
    """Each saved input (--out's folders) run again: its outcome, or how it escapes."""
    from fuzz_harness import Escape, check_case, load_saved

    escaped = 0
    with tempfile.TemporaryDirectory(prefix="lift-gl-fuzz-") as tmp:
        for folder in folders:
            target, case = load_saved(folder)
            try:
                outcome = check_case(target, case, Path(tmp) / "root")
                print(f"{folder}: {target.name}: {outcome.kind} {outcome.message}")
            except Escape as escape:
                escaped += 1
                print(f"{folder}: {target.name}: ESCAPED {escape}")
    return 1 if escaped else 0


def machine(commit: str | None = None) -> dict:
    """Where the run was made: CPU, cores, load, Python, the commit and whether the tree was clean."""
    import platform

    cpu = next((line.split(":", 1)[1].strip() for line in Path("/proc/cpuinfo").read_text().splitlines()
                if line.startswith("model name")), platform.processor()) if Path("/proc/cpuinfo").exists() \
        else platform.processor()

    def git(*args):
        return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True).stdout.strip()
    if commit or not (ROOT / ".git").exists():  # a copy of the tree whose .git, if any, is not its own
        return {"cpu": cpu, "cores": os.cpu_count(), "load_average": os.getloadavg(),
                "python": platform.python_version(), "commit": commit or "unknown", "uncommitted_loader_changes": False}
    return {"cpu": cpu, "cores": os.cpu_count(), "load_average": os.getloadavg(), "python": platform.python_version(),
            "commit": git("rev-parse", "--short", "HEAD"),
            "uncommitted_loader_changes": bool(git("status", "--porcelain", "--", "lift_gl"))}


def write_results(results: Path, command: str, where: dict, rows: list, shards: list) -> None:
    where = dict(where, load_average_end=os.getloadavg())
    head = (f"`{command}` at commit {where['commit']}"
            + (" (with uncommitted changes to lift_gl/)" if where["uncommitted_loader_changes"] else "")
            + f"; {where['cpu']}, {where['cores']} cores, load {where['load_average'][0]:.1f} at the start "
              f"and {where['load_average_end'][0]:.1f} at the end, Python {where['python']}")
    results.parent.mkdir(parents=True, exist_ok=True)
    results.with_suffix(".md").write_text(f"{head}\n\n{table(rows)}\n\nEscapes:\n\n{escapes_text(rows)}\n")
    results.with_suffix(".json").write_text(json.dumps({"command": command, "machine": where, "rows": rows,
                                                       "shards": shards}, indent=1) + "\n")


def _command_args(argv: list[str]) -> list[str]:
    """The command line as recorded: without --resume, and without this machine's paths."""
    kept, skip = [], False
    for arg in argv:
        if skip:
            skip = False
        elif arg in ("--results", "--out", "--commit"):
            skip = True
        elif arg != "--resume" and not arg.startswith(("--results=", "--out=", "--commit=")):
            kept.append(arg)
    return kept


def finished_shards(results: Path, plan_key: dict) -> list[dict]:
    """The shards an earlier run of the same plan (cases, seed, shard size) wrote to `results`."""
    path = results.with_suffix(".json")
    if not path.exists():
        return []
    shards = json.loads(path.read_text()).get("shards", [])
    return [sh for sh in shards if all(sh.get(k) == v for k, v in plan_key.items())]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cases", type=int, default=10000, help="inputs per loader (default 10000)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--shard-size", type=int, default=1000, help="inputs per worker run (default 1000)")
    parser.add_argument("--only", help="fuzz only the loaders whose name contains this (comma-separated)")
    parser.add_argument("--out", default="out/fuzz", help="where escaping inputs are saved")
    parser.add_argument("--results", default=str(RESULTS), help="results file, without extension (.md, .json)")
    parser.add_argument("--resume", action="store_true",
                        help="keep the shards already in --results (same --cases, --seed, --shard-size), run the rest")
    parser.add_argument("--stall", type=float, default=120.0, help="seconds of silence that count as a hang")
    parser.add_argument("--jobs", type=int, default=1, help="shards fuzzed at once, a worker process each")
    parser.add_argument("--replay", nargs="+", metavar="FOLDER", help="run saved inputs again and print their outcomes")
    parser.add_argument("--commit", help="the commit to record (a copy of the tree on another machine, whose .git "
                        "may be missing or stale)")
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    parser.add_argument("--root", help=argparse.SUPPRESS)
    args = parser.parse_args()
    out = Path(args.out).resolve()
    if args.worker:
        worker(args.worker, args.cases, args.seed, Path(args.root), out)
        return 0
    if args.replay:
        return replay([Path(f) for f in args.replay])
    from fuzz_harness import TARGETS

    wanted = [w.strip().lower() for w in args.only.split(",")] if args.only else None
    where = machine(args.commit)
    results = Path(args.results)
    command = ("python benchmarks/fuzz_loaders.py " + " ".join(_command_args(sys.argv[1:]))).strip()
    names = [t.name for t in TARGETS if not wanted or any(w in t.name.lower() for w in wanted)]
    plan_key = {"cases": args.cases, "seed": args.seed, "shard_size": args.shard_size}
    shards = finished_shards(results, plan_key) if args.resume else []
    have = {(sh["target"], sh["index"]) for sh in shards}
    todo = [(name, index, size) for name in names
            for index, size in enumerate(shard_plan(args.cases, args.shard_size)) if (name, index) not in have]
    if shards:
        print(f"resuming: {len(shards)} shards done, {len(todo)} to run", file=sys.stderr)
    lock = threading.Lock()

    def rows_now() -> list[dict]:
        return [merge_rows(n, [sh["row"] for sh in shards if sh["target"] == n]) for n in names
                if any(sh["target"] == n for sh in shards)]

    def run(name, index, size):
        row = fuzz_target(name, size, args.seed + SHARD_SEED_STRIDE * index, out, args.stall)
        with lock:  # after each shard: a long run's part survives
            shards.append(dict(plan_key, target=name, index=index, row=row))
            write_results(results, command, where, rows_now(), shards)

    with ThreadPoolExecutor(max_workers=args.jobs) as pool:
        for future in [pool.submit(run, *task) for task in todo]:
            future.result()
    rows = rows_now()
    print(table(rows))
    print("\nEscapes:\n" + escapes_text(rows))
    return 1 if any(r["escaped"] for r in rows) else 0


if __name__ == "__main__":
    sys.exit(main())
