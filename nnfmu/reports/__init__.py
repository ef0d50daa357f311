"""nnfmu's HTML reports: one jinja2 environment, one page skeleton every report's template extends, atomic writes."""
