"""Self-contained HTML reports of saved runs (plots embedded as PNG)."""
