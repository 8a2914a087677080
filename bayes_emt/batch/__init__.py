"""Batch runs: many recordings in parallel on Dask distributed, resumable, one folder per file
plus a summary table (``bayes-emt batch``)::

    from bayes_emt.batch import BatchSettings, run_batch
    result = run_batch("recordings/", "batch_out", BatchSettings(jobs=("fit", "sample"), model="UD"))
    result.counts            # {'done': 18, 'error': 2, 'pending': 0}
"""

from .inputs import BatchInput, find_inputs
from .jobs import JOBS, BatchSettings, FileOutcome, is_finished, process_file
from .runner import BatchResult, open_client, run_batch
from .summary import summary_rows, write_summary

__all__ = ["JOBS", "BatchInput", "BatchResult", "BatchSettings", "FileOutcome", "find_inputs", "is_finished",
           "open_client", "process_file", "run_batch", "summary_rows", "write_summary"]
