"""The live-compensation register interface (docs/compensation.md, "Live compensation interface"):
:mod:`.codec` (pure encoding of the registers) and :mod:`.client` (the compensator's Modbus client)."""
