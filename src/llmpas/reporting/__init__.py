"""Web reports of runs: ``index.html`` in a run folder (:func:`build_report`), rebuilt from the
files on disk, and the browser that checks and photographs them (:mod:`.browser`)."""

from llmpas.reporting.page import Built, build_report, render
from llmpas.reporting.run_folder import ReportError, RunRecord, read_run

__all__ = ["Built", "ReportError", "RunRecord", "build_report", "read_run", "render"]
