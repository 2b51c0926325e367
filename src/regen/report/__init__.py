"""The run report: one offline HTML page about a run folder (``RUN/report.html``)."""

from regen.report.html import render_report, write_report
from regen.report.load import RunView, ScenarioView, load_run

__all__ = ["RunView", "ScenarioView", "load_run", "render_report", "write_report"]
