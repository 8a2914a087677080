"""The report: one self-contained HTML page rendered from a run folder's saved outputs.

:func:`build_report` reads the JSON files, netCDF posteriors and PNG figures a run wrote (their
names in :mod:`bayes_emt.report.layout`), embeds the figures and renders the Jinja2 templates
shipped in ``templates/``; a section whose outputs are absent says plainly that it was not run.
"""

from .render import build_report, render_report

__all__ = ["build_report", "render_report"]
