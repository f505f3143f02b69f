"""The Ray backend: one Ray task per run on a local Ray instance or an existing cluster.

``ray.init()`` with the given address (``"auto"``, ``"host:port"`` of a cluster's head), or a
local instance when none is given. Each run is a task with ``num_cpus=1``; Ray's own retry
(``max_retries=1``) re-runs a run whose worker process died, and a second death records the run
as "failed". Ray keeps its worker processes between tasks, so each pays the imports once. The
task is :func:`twin.campaign.runner.execute_run`, the same function the local pool runs: per-run
numbers are the same whatever the backend.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from twin.campaign.spec import RunSpec


def run_on_ray(
    todo: list[RunSpec],
    job: dict[str, Any],
    record: Callable[[dict[str, Any]], None],
    *,
    address: str | None = None,
    num_cpus: int | None = None,
) -> None:
    """Run ``todo`` as Ray tasks; ``record`` gets each row as its task finishes."""
    import ray

    from twin.campaign.runner import _failed, execute_run

    started = False
    if not ray.is_initialized():
        ray.init(
            address=address,
            num_cpus=num_cpus if address is None else None,
            include_dashboard=False,
            log_to_driver=False,
            configure_logging=False,
        )
        started = True
    task = ray.remote(num_cpus=1, max_retries=1)(execute_run)
    # The job (the campaign's scenario and settings) goes to the object store once; each task
    # gets a reference, which Ray resolves before the call, instead of a copy serialized per run.
    job_ref = ray.put(job)
    refs = {task.remote(r, job_ref): r for r in todo}
    pending = list(refs)
    try:
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            for ref in done:
                r = refs[ref]
                try:
                    row = ray.get(ref)
                except ray.exceptions.WorkerCrashedError:
                    row = _failed(r, "the Ray worker died twice (crash or out of memory)")
                except ray.exceptions.RayError as exc:
                    row = _failed(r, f"Ray: {type(exc).__name__}: {exc}".splitlines()[0])
                record(row)
    except KeyboardInterrupt:
        for ref in pending:
            ray.cancel(ref, force=True)
        raise
    finally:
        if started:
            ray.shutdown()
