"""Many behaviors from one spec (``regen batch``): :func:`run_batch`, its spec
(:mod:`regen.batch.spec`), its record and summary."""

from regen.batch.runner import BatchRecord, run_batch
from regen.batch.spec import BatchSpec, read_spec
from regen.batch.summary import summarize_batch, write_batch_report

__all__ = ["BatchRecord", "BatchSpec", "read_spec", "run_batch", "summarize_batch", "write_batch_report"]
