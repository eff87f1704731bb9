"""Multi-body volumetric error model of a machine tool (seeds 000, 002, 004; docs/volumetric.md).

Pure functions on arrays: the model (:mod:`.model`), value curves (:mod:`.curves`), the chain
of homogeneous transforms (:mod:`.chain`, with :mod:`.rotations` and the component-wise
:mod:`.components`), first-order and exact evaluation vectorised over poses (:mod:`.evaluate`) and
per-axis compensation tables with the cross terms they cannot hold (:mod:`.axis_tables`).
"""
