"""Joining Ray: the ``ray`` extra, a one-machine instance on loopback, or a running cluster.

``connect(None)`` starts a single-node Ray instance for this process, bound to 127.0.0.1 only
(a one-machine run has no reason to listen on the network). ``connect("auto")`` joins the
cluster started on this machine with ``ray start``; ``connect("HOST:PORT")`` joins the cluster
whose head listens there, after checking within seconds that something answers at that address.
"""

from __future__ import annotations

import os
import socket

from rbenv.core.errors import RbenvValueError

from rbenv.satellite.usage import MissingExtraError

INSTALL = ('pip install -e ".[ray]"  (Ray pins gymnasium==1.2.2, so use a venv of its own, '
           'e.g. python3 -m venv .venv-ray && .venv-ray/bin/pip install torch==2.13.0 && '
           '.venv-ray/bin/pip install -e ".[ray]")')
# Environment variable that keeps a Ray node on 127.0.0.1 (single node only).
LOOPBACK_ENV = "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"
CONNECT_TIMEOUT_S = 5.0


class RayAddressError(RbenvValueError):
    """``--address`` names no reachable Ray cluster."""


def require_ray(feature: str = "this command"):
    """The ``ray`` module, or :class:`MissingExtraError` naming the install command."""
    try:
        import ray  # the ray extra
        from ray import tune  # noqa: F401  (the extra installs rllib and tune together)
    except ImportError as e:
        raise MissingExtraError(f"{feature} needs Ray RLlib and Tune, which are not installed "
                                f"({e.name or e}); install the ray extra: {INSTALL}") from None
    return ray


def split_address(address: str) -> tuple[str, int]:
    """``(host, port)`` of ``HOST:PORT``; :class:`RayAddressError` naming the value otherwise."""
    host, sep, port = str(address).rpartition(":")
    if not sep or not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise RayAddressError(f"address must be 'auto' or HOST:PORT of a Ray head (e.g. "
                              f"10.0.0.5:6379), got {address!r}")
    return host.strip("[]"), int(port)


def check_reachable(address: str, timeout_s: float = CONNECT_TIMEOUT_S) -> None:
    """Raise :class:`RayAddressError` naming ``address`` unless a TCP connect succeeds there."""
    host, port = split_address(address)
    try:
        with socket.create_connection((host, port), timeout=timeout_s):
            pass
    except OSError as e:
        raise RayAddressError(f"no Ray cluster answers at address {address!r} ({e}); start one "
                              f"with `ray start --head --port {port}` on {host}, or check the "
                              "address") from None


def connect(address: str | None = None, *, num_cpus: int | None = None,
            feature: str = "this command") -> bool:
    """Initialise Ray for this process; returns True if this call started it (caller shuts down).

    ``address`` None: a private single-node instance on 127.0.0.1 (``num_cpus`` caps it);
    ``"auto"``: the cluster started on this machine; ``HOST:PORT``: that cluster's head.
    """
    if address is None:
        os.environ.setdefault(LOOPBACK_ENV, "0")  # read when ray is first imported
    ray = require_ray(feature)
    if ray.is_initialized():
        return False
    kwargs = {"include_dashboard": False, "log_to_driver": True,
              "runtime_env": {"env_vars": {"OMP_NUM_THREADS": "1"}}}
    if address is None:
        ray.init(num_cpus=num_cpus, **kwargs)
        return True
    if address != "auto":
        check_reachable(address)
    _match_token_auth()
    try:
        ray.init(address=address, **kwargs)
    except (ConnectionError, RuntimeError, ValueError) as e:
        raise RayAddressError(f"could not join the Ray cluster at address {address!r}: "
                              f"{type(e).__name__}: {e}") from None
    return True


def _match_token_auth() -> None:
    """Use token authentication when this machine has a Ray token, as ``ray start`` does.

    ``ray start`` turns token authentication on whenever a token exists (``RAY_AUTH_TOKEN``, or
    the file at ``RAY_AUTH_TOKEN_PATH`` or ``~/.ray/auth_token``) and ``RAY_AUTH_MODE`` is
    unset; a driver joining that cluster must then send it too.
    """
    if "RAY_AUTH_MODE" in os.environ:
        return
    path = os.environ.get("RAY_AUTH_TOKEN_PATH") or os.path.expanduser("~/.ray/auth_token")
    if os.environ.get("RAY_AUTH_TOKEN") or os.path.isfile(path):
        os.environ["RAY_AUTH_MODE"] = "token"


def shutdown(started: bool) -> None:
    """Shut Ray down if :func:`connect` started it in this process."""
    if started:
        import ray  # the ray extra

        ray.shutdown()
