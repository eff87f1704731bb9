"""Workflows as plans: generators of :mod:`acquisition.messages`."""

from .straightness import straightness_plan

__all__ = ["straightness_plan"]
