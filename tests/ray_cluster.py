"""A Ray cluster on this machine for the tests: one node of N CPUs (N workers), every process
on 127.0.0.1. Ray would take this machine's outward address for "127.0.0.1" (to be reachable
from other machines); RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0 in the processes' environment keeps it
on the loopback address, for one node only. A command that joins it needs `env`."""
from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class LocalCluster:
    def __init__(self, workers: int = 2, object_store_bytes: int = 80_000_000):
        self.ray = str(Path(sys.executable).with_name("ray"))
        self.port = free_port()
        self.address = f"127.0.0.1:{self.port}"
        self.temp = tempfile.mkdtemp(prefix="lgray", dir="/tmp")   # short: Ray's unix sockets live under it
        self.env = dict(os.environ, RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER="0", RAY_USAGE_STATS_ENABLED="0",
                        PYTHONPATH=os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")])))
        self.log = Path(self.temp) / "head.log"
        with open(self.log, "wb") as log:
            self.head = subprocess.Popen(
                [self.ray, "start", "--head", "--block", f"--port={self.port}", "--node-ip-address=127.0.0.1",
                 f"--num-cpus={workers}", "--num-gpus=0", "--include-dashboard=false", f"--temp-dir={self.temp}",
                 f"--object-store-memory={object_store_bytes}", "--disable-usage-stats"],
                env=self.env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        try:
            self._wait_for(workers)
        except BaseException:
            self.stop()
            raise

    def _wait_for(self, cpus: int, timeout: float = 120.0) -> None:
        """Until the cluster reports `cpus` CPUs (asked in a child: this process stays unjoined)."""
        probe = ("import ray,sys; ray.init(address=sys.argv[1], logging_level='error'); "
                 "print(int(ray.cluster_resources().get('CPU', 0)))")
        deadline = time.monotonic() + timeout
        out = None
        while time.monotonic() < deadline and self.head.poll() is None:
            out = subprocess.run([sys.executable, "-c", probe, self.address], env=self.env, capture_output=True,
                                 text=True, timeout=60)
            if out.returncode == 0 and out.stdout.strip().splitlines()[-1:] == [str(cpus)]:
                return
            time.sleep(1.0)
        raise RuntimeError(f"the local Ray cluster did not start ({out.stderr[-500:] if out else ''}):\n"
                           + self.log.read_text(errors="replace")[-2000:])

    def stop(self) -> None:
        try:
            os.killpg(self.head.pid, signal.SIGKILL)   # the node: raylet, GCS, workers
        except (ProcessLookupError, PermissionError):
            pass
        self.head.wait()
        shutil.rmtree(self.temp, ignore_errors=True)
