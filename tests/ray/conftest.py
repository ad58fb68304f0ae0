"""Ray test helpers: nodes started with ``ray start --block`` and stopped by pid.

Every Ray node a test starts binds to 127.0.0.1 or to an address of a network namespace the
test made itself, has its own short ``--temp-dir``, and is stopped with SIGTERM to the pid of
its ``ray start --block`` process; :meth:`RayNode.stop` then checks that no process whose
command line names that temp dir is left (and SIGKILLs those by pid if some are).
"""

from __future__ import annotations

import os
import secrets
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
RAY = str(Path(sys.executable).with_name("ray"))
TOKEN = secrets.token_hex(16)  # every node and driver of these tests shares it


def ray_env(loopback: bool) -> dict:
    """Environment for Ray processes: no usage stats; ``loopback`` keeps a node on 127.0.0.1."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("RAY_")}
    env.update({"RAY_USAGE_STATS_ENABLED": "0", "OMP_NUM_THREADS": "1", "PYTHONUNBUFFERED": "1",
                "PYTHONPATH": str(REPO), "RAY_AUTH_MODE": "token", "RAY_AUTH_TOKEN": TOKEN})
    if loopback:
        env["RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"] = "0"
    return env


def free_port(host: str = "127.0.0.1") -> int:
    with socket.socket() as s:
        s.bind((host, 0))
        return s.getsockname()[1]


def processes_naming(text: str) -> list[int]:
    """Pids of live processes whose command line contains ``text``."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit() or int(entry.name) == os.getpid():
            continue
        try:
            cmdline = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
            state = next((line for line in (entry / "status").read_text().splitlines()
                          if line.startswith("State:")), "")
        except OSError:
            continue
        if text in cmdline and "zombie" not in state:
            found.append(int(entry.name))
    return found


class RayNode:
    """``ray start --block`` (head or worker) in the background, optionally in a namespace."""

    def __init__(self, args: list[str], env: dict, netns: str | None = None):
        self.temp_dir = tempfile.mkdtemp(prefix="rbt", dir="/tmp")  # short: socket path limit
        prefix = ["ip", "netns", "exec", netns] if netns else []
        self.cmd = [*prefix, RAY, "start", "--block", "--disable-usage-stats",
                    f"--temp-dir={self.temp_dir}", *args]
        self.log = open(Path(self.temp_dir) / "ray_start.log", "w")
        self.proc = subprocess.Popen(self.cmd, env=env, stdout=self.log,
                                     stderr=subprocess.STDOUT, start_new_session=True)
        self.leftover: list[int] = []

    def output(self) -> str:
        self.log.flush()
        return (Path(self.temp_dir) / "ray_start.log").read_text()

    def stop(self, timeout_s: float = 60.0) -> None:
        """SIGTERM the ``ray start`` pid; record (and kill by pid) processes that outlive it."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout_s)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        deadline = time.monotonic() + 20
        while processes_naming(self.temp_dir) and time.monotonic() < deadline:
            time.sleep(0.5)
        self.leftover = processes_naming(self.temp_dir)
        for pid in self.leftover:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        self.log.close()
        shutil.rmtree(self.temp_dir, ignore_errors=True)


def wait_for_nodes(address: str, count: int, env: dict, netns: str | None = None,
                   timeout_s: float = 120) -> None:
    """Wait until the cluster at ``address`` has ``count`` alive nodes."""
    prefix = ["ip", "netns", "exec", netns] if netns else []
    code = ("import ray, sys; ray.init(address=sys.argv[1], include_dashboard=False, "
            "log_to_driver=False); print(sum(n['Alive'] for n in ray.nodes()))")
    deadline, last = time.monotonic() + timeout_s, ""
    while time.monotonic() < deadline:
        r = subprocess.run([*prefix, sys.executable, "-c", code, address], env=env,
                           capture_output=True, text=True, timeout=120)
        last = r.stdout.strip().splitlines()[-1:] or [r.stderr[-500:]]
        if r.returncode == 0 and last[0].isdigit() and int(last[0]) >= count:
            return
        time.sleep(2)
    raise AssertionError(f"cluster at {address} did not reach {count} nodes: {last}")


@pytest.fixture
def raytools():
    """The helpers above, for test modules (which cannot import conftest); skips without Ray."""
    from types import SimpleNamespace

    pytest.importorskip("ray", reason="the ray extra is not installed (pip install -e '.[ray]')")
    return SimpleNamespace(RayNode=RayNode, wait_for_nodes=wait_for_nodes, free_port=free_port,
                           processes_naming=processes_naming, ray_env=ray_env, REPO=REPO)
