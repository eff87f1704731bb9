"""The volumetric machine model from a machine file (docs/volumetric.md): reading the file and the
run directories it names, the error over a grid or at one pose, the files, per-axis export."""
