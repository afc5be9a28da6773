"""Ray for `tether-sweep`: started here or joined, its log in the sweep's folder, Ctrl-C safe.

`start_ray` starts a local Ray or joins the cluster at `--address`. Ray cannot be interrupted
half-started without leaving its processes behind, so a Ctrl-C while it starts is noted and
acted on once it has started (`ray.shutdown` then stops every process it started). A cluster
that refuses the connection, most often for Ray's token authentication (`RAY_AUTH_MODE=token`
and the cluster's token, the same on every node and for every client), ends in one line saying
what to do (`ClusterError`). `ray_log_to` keeps Ray's and Tune's log in a file, and off the
console for a local Ray (only warnings and errors of a cluster's).
"""

from __future__ import annotations

import logging
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, TextIO

import ray

AUTH_HELP = (
    "export RAY_AUTH_MODE=token and the cluster's token (`ray get-auth-token` on its head "
    "node) as RAY_AUTH_TOKEN or in ~/.ray/auth_token, as on every node of the cluster"
)
"""What a client of a cluster with token authentication needs (Ray 2.52 and later)."""
AUTH_SIGNS = ("InvalidAuthToken", "Unauthenticated", "authentication token")
"""Words of Ray's errors when a cluster refuses a client's token (or its lack of one)."""


class ClusterError(RuntimeError):
    """Ray could not be started or joined; the message says what to do, in one line."""


@contextmanager
def deferred_interrupt(note: str) -> Iterator[Callable[[], bool]]:
    """Within the block a Ctrl-C (SIGINT) prints `note` and is noted instead of raised; the
    block gets a function telling whether one came. Outside the main thread (where no signal
    handler can be set) nothing is deferred."""
    if threading.current_thread() is not threading.main_thread():
        yield lambda: False
        return
    received: list[int] = []

    def note_it(signum: int, frame: Any) -> None:
        if not received:
            print(note, file=sys.stderr, flush=True)
        received.append(signum)

    previous = signal.signal(signal.SIGINT, note_it)
    try:
        yield lambda: bool(received)
    finally:
        signal.signal(signal.SIGINT, previous)


def refusal(error: BaseException, address: str) -> str:
    """The one line for an error of `ray.init(address=...)`: a refused token, or no cluster."""
    chain, seen = [], error
    while seen is not None and len(chain) < 10:
        chain.append(f"{type(seen).__name__}: {seen}")
        seen = seen.__cause__ or seen.__context__
    if any(sign in text for text in chain for sign in AUTH_SIGNS):
        refused = f"the Ray cluster at {address} refused the connection (token authentication)"
        return f"{refused}: {AUTH_HELP}"
    return (
        f"cannot join a Ray cluster at {address} ({chain[0].splitlines()[0]}): start one with "
        "`ray start --head`, or drop --address to run Ray here"
    )


def start_ray(address: str | None, runtime_env: dict[str, Any]) -> None:
    """Start Ray here (`address` None) or join the cluster at `address` ("auto" or
    HOST:PORT), with the trials' `runtime_env`; the trials' output goes to their log files, not
    to this console.

    Raises:
        ClusterError: the cluster refused or did not answer (one line saying what to do).
        KeyboardInterrupt: Ctrl-C came while Ray started (Ray is stopped again first).
    """
    note = "Ctrl-C: stopping once Ray has started"
    try:
        with deferred_interrupt(note) as interrupted:
            ray.init(
                address=address or "local",
                include_dashboard=False,
                runtime_env=runtime_env,
                log_to_driver=False,
            )
    except (ConnectionError, RuntimeError, ray.exceptions.RayError) as error:
        ray.shutdown()
        raise ClusterError(refusal(error, address or "local")) from None
    if interrupted():
        ray.shutdown()
        raise KeyboardInterrupt


def _not_tune_resume_hint(record: logging.LogRecord) -> bool:
    """False for Tune's "Resume experiment with: Tuner.restore(...)": the command says how to
    continue a sweep itself (`tether-sweep --resume DIR`)."""
    return "Tuner.restore(" not in record.getMessage()


@contextmanager
def ray_log_to(path: Path, local: bool) -> Iterator[TextIO]:
    """Ray's and Tune's log (the "ray" logger, from INFO) appended to `path`, whose stream the
    block gets (for Tune's console report). Meanwhile the logger's console handlers show
    nothing for a `local` Ray (its token-authentication notice included: the command prints
    what matters), and only warnings and errors of a cluster's; never Tune's resume hint."""
    logger = logging.getLogger("ray")
    console = [(handler, handler.level) for handler in logger.handlers]
    quiet = logging.CRITICAL + 1 if local else logging.WARNING
    for handler, _ in console:
        handler.setLevel(max(handler.level, quiet))
        handler.addFilter(_not_tune_resume_hint)
    with path.open("a") as stream:
        log_file = logging.StreamHandler(stream)
        log_file.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(name)s: %(message)s"))
        logger.addHandler(log_file)
        try:
            yield stream
        finally:
            logger.removeHandler(log_file)
            for handler, level in console:
                handler.setLevel(level)
                handler.removeFilter(_not_tune_resume_hint)
