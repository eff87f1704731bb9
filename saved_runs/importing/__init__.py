"""Run directories from data measured with another tool (``guideway import``)."""
