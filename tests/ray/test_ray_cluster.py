"""A real two-host Ray cluster on one machine: two network namespaces joined by a veth pair.

The head runs in one namespace and a worker in the other, each with one CPU and its own temp
dir; a small suite sweep runs through the command line from the head's namespace against
``--address <head>:<port>``. Checked: trials ran on both nodes, every cell's result is complete
at the driver, every Ray process started is stopped by pid, the namespaces are deleted.
Needs root and iproute2; skips with the reason otherwise.

Token authentication is on, as the README's cluster steps set it up: every node and the driver
get ``RAY_AUTH_MODE=token`` and one token (``conftest.ray_env``), and a driver holding another
token is refused, so the test would fail if the cluster ran without authentication.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys

import pytest

SUBNET = "10.213.47"  # the test's own addresses, only inside its own namespaces
HEAD_IP, WORKER_IP = f"{SUBNET}.1", f"{SUBNET}.2"


def _run(*cmd: str) -> None:
    subprocess.run(cmd, check=True, capture_output=True, text=True, timeout=30)


def _namespaces_available() -> str | None:
    if os.geteuid() != 0:
        return "making network namespaces needs root"
    if shutil.which("ip") is None:
        return "iproute2's ip command is missing (apt-get install iproute2)"
    return None


@pytest.fixture
def two_hosts():
    """Two namespaces joined by a veth pair: (head namespace, worker namespace)."""
    reason = _namespaces_available()
    if reason:
        pytest.skip(reason)
    tag = f"{os.getpid() % 100000}"
    ns1, ns2, v1, v2 = f"rbh1-{tag}", f"rbh2-{tag}", f"rbv1-{tag}", f"rbv2-{tag}"
    made = []
    try:
        for ns in (ns1, ns2):
            _run("ip", "netns", "add", ns)
            made.append(ns)
            _run("ip", "-n", ns, "link", "set", "lo", "up")
        _run("ip", "link", "add", v1, "netns", ns1, "type", "veth", "peer", "name", v2,
             "netns", ns2)
        for ns, dev, ip in ((ns1, v1, HEAD_IP), (ns2, v2, WORKER_IP)):
            _run("ip", "-n", ns, "addr", "add", f"{ip}/24", "dev", dev)
            _run("ip", "-n", ns, "link", "set", dev, "up")
        _run("ip", "netns", "exec", ns1, "ping", "-c", "1", "-W", "5", WORKER_IP) \
            if shutil.which("ping") else None
    except subprocess.CalledProcessError as e:
        for ns in made:
            subprocess.run(["ip", "netns", "del", ns], capture_output=True)
        pytest.skip(f"network namespaces cannot be made here: {' '.join(e.cmd)}: "
                    f"{e.stderr.strip()}")
    yield ns1, ns2
    for ns in made:
        subprocess.run(["ip", "netns", "del", ns], capture_output=True, timeout=30)
    listed = subprocess.run(["ip", "netns", "list"], capture_output=True, text=True).stdout
    assert not any(ns in listed for ns in made), f"namespaces left: {listed}"


def _refuses_another_token(address: str, env: dict, netns: str) -> None:
    """A driver with a token other than the cluster's cannot join it."""
    assert env["RAY_AUTH_MODE"] == "token" and env["RAY_AUTH_TOKEN"]
    wrong = {**env, "RAY_AUTH_TOKEN": "0" * len(env["RAY_AUTH_TOKEN"])}
    code = ("import ray, sys; ray.init(address=sys.argv[1], include_dashboard=False, "
            "log_to_driver=False); print('joined', len(ray.nodes()))")
    try:
        r = subprocess.run(["ip", "netns", "exec", netns, sys.executable, "-c", code, address],
                           env=wrong, capture_output=True, text=True, timeout=180)
    except subprocess.TimeoutExpired:
        return  # still retrying after 3 min: it never joined
    assert "joined" not in r.stdout and r.returncode != 0, r.stdout[-2000:] + r.stderr[-2000:]
    assert "auth" in (r.stdout + r.stderr).lower(), r.stderr[-2000:]


def test_sweep_on_two_node_cluster(raytools, two_hosts, tmp_path):
    ns1, ns2 = two_hosts
    env = raytools.ray_env(loopback=False)  # a multi-node cluster, on the namespaces' addresses
    port = 6391
    address = f"{HEAD_IP}:{port}"
    nodes = [raytools.RayNode(["--head", f"--node-ip-address={HEAD_IP}", f"--port={port}",
                               "--num-cpus=1", "--include-dashboard=false"], env, netns=ns1)]
    try:
        raytools.wait_for_nodes(address, 1, env, netns=ns1)
        nodes.append(raytools.RayNode([f"--address={address}", f"--node-ip-address={WORKER_IP}",
                                       "--num-cpus=1"], env, netns=ns2))
        raytools.wait_for_nodes(address, 2, env, netns=ns1)
        _refuses_another_token(address, env, ns1)
        out = tmp_path / "suite"
        cmd = ["ip", "netns", "exec", ns1, sys.executable, "-m", "rbenv.agents.training.tune",
               "--ray",
               "--address", address, "--quick", "--timesteps", "2048", "--episodes", "4",
               "--out", str(out)]
        r = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=900,
                           cwd=raytools.REPO)
        assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
        suite = json.loads((out / "suite.json").read_text())
        placement = json.loads((out / "tune_placement.json").read_text())
        assert suite["missing"] == []
        # suite.json names the cells; each cell's figures are in cells/<name>/result.json.
        cells = [json.loads((out / "cells" / name / "result.json").read_text())
                 for name in suite["cells"]]
        assert len(cells) == 2 and {c["task"] for c in cells} == {"detumble", "reorient"}
        assert all(c["policy"]["episodes"] == 4 for c in cells)
        assert {p["node_ip"] for p in placement.values()} == {HEAD_IP, WORKER_IP}
    finally:
        for node in reversed(nodes):
            node.stop()
    assert [n.leftover for n in nodes] == [[], []], "Ray processes outlived SIGTERM"
    assert all(n.proc.returncode is not None for n in nodes)
