"""Reports: tables (CSV, Markdown, rich) and figures (matplotlib), pure functions of results."""
