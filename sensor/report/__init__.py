"""Self-contained HTML reports: :mod:`sensor.report.html` holds what every report shares
(embedding figures, the Jinja2 templates, writing the page), :mod:`sensor.report.design_report`
the report of one design (``dacm report``)."""
