"""--executor local|ray and --address HOST:PORT, as `grade` and `compare` take them."""
from __future__ import annotations

from dataclasses import dataclass

from ..errors import LiftError

EXECUTORS = ("local", "ray")
DEFAULT_SEEDS_PER_TASK = 8


@dataclass(frozen=True)
class ExecutorSettings:
    kind: str = "local"
    address: str | None = None       # HOST:PORT of the Ray head (None with ray: a local one of its own)
    seeds_per_task: int = DEFAULT_SEEDS_PER_TASK
    retries: int = 2                 # a task whose worker died is run again this many times
    workers: int | None = None       # actors (None: one a GPU, or a CPU where the cluster has no GPU)

    def __post_init__(self):
        if self.kind not in EXECUTORS:
            raise LiftError(f"--executor must be one of {', '.join(EXECUTORS)}, not {self.kind!r}")
        if self.kind == "local" and self.address is not None:
            raise LiftError("--address needs --executor ray")
        if self.seeds_per_task < 1 or self.retries < 0 or (self.workers is not None and self.workers < 1):
            raise LiftError("--seeds-per-task and --workers must be at least 1, --retries at least 0")


def add_executor_arguments(parser) -> None:
    from ..arg_types import positive_int

    group = parser.add_argument_group("running on a Ray cluster (docs/cluster.md)")
    group.add_argument("--executor", choices=EXECUTORS, default="local",
                       help="local: this machine (default); ray: a Ray cluster's workers, one a GPU or CPU slot "
                            "(pip install 'lift-gl[cluster]')")
    group.add_argument("--address", metavar="HOST:PORT", help="the Ray head to join (with --executor ray)")
    group.add_argument("--seeds-per-task", type=positive_int, default=DEFAULT_SEEDS_PER_TASK,
                       help=f"seeds one task renders (default {DEFAULT_SEEDS_PER_TASK}); the work is split by "
                            "submission x scene x seeds")
    group.add_argument("--workers", type=positive_int,
                       help="actors to start (default: one a GPU of the cluster, or a CPU where it has none)")
    group.add_argument("--retries", type=int, default=2,
                       help="times a task whose worker was lost is run again elsewhere (default 2)")


def executor_from_args(args) -> ExecutorSettings:
    return ExecutorSettings(args.executor, args.address, args.seeds_per_task, args.retries, args.workers)
