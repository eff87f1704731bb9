"""``guideway diagnose``: model files, the diagnosis of a run against its model, and its report."""
