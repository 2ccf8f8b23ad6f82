"""The report of a run: paper-style tables (CSV, Markdown, LaTeX), figures and one offline ``report.html``."""
