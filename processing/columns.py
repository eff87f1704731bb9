"""Column schemas of the DataFrames processing consumes and produces.

``STRAIGHTNESS_POINTS`` are the columns of a straightness run's points.csv
(run format version 1); processing functions take a DataFrame with at least
these columns.  Units are in the names.
"""

STRAIGHTNESS_POINTS: tuple[str, ...] = (
    "station",          # station index k (0 = datum)
    "x_mm",             # nominal position of the block, k * block length
    "time_s",           # seconds since the run started
    "lin_um",           # P displacement along X minus nominal travel
    "stry_um",          # P displacement along Y (straightness Y)
    "strz_um",          # P displacement along Z (straightness Z)
    "pitch_urad",       # block rotation about Z
    "yaw_urad",         # block rotation about Y
    "roll_urad",        # block rotation about X
    "sensor_mm",        # displacement sensor reading, sensor's own sign (see sensor_sign)
    "air_temp_c",
    "air_pressure_hpa",
    "humidity_pct",
    "material_temp_c",
)

# Columns added by run format version 2, with the value a file without them implies.
# ``pass``: 0 forward pass, 1 return pass of a straightness run.
# ``not_still``: 1 when the operator captured the point although the stability rule
# (acquisition.stillness) did not find the block / axis still, else 0; every kind, last column;
# runs written before it existed read as 0 (docs/run-format.md).
STRAIGHTNESS_POINTS_V2: tuple[str, ...] = (*STRAIGHTNESS_POINTS, "pass", "not_still")
OPTIONAL_DEFAULTS: dict[str, float] = {"pass": 0, "not_still": 0}

PROFILE: tuple[str, ...] = (
    "station",    # station index
    "x_mm",       # position of the surface sample point relative to the first station (exact: actual; else nominal)
    "height_um",  # surface height (+Y) at the sample point relative to the first station
)

ENVIRONMENT: tuple[str, ...] = ("air_temp_c", "air_pressure_hpa", "humidity_pct", "material_temp_c")
ERROR_CHANNELS: tuple[str, ...] = ("stry_um", "strz_um", "pitch_urad", "yaw_urad", "roll_urad")

# points.csv of an ISO 230-2 positioning run (run format version 2).  ``direction``
# is +1 or -1; ``run`` counts the approaches in each direction from 1.  A linear
# axis uses target_mm/reading_mm, a rotary axis target_deg/reading_deg.
POSITIONING_LINEAR: tuple[str, ...] = (
    "run", "direction", "target_index", "target_mm", "reading_mm", "time_s",
    *ERROR_CHANNELS, *ENVIRONMENT, "not_still",
)
POSITIONING_ROTARY: tuple[str, ...] = (
    "run", "direction", "target_index", "target_deg", "reading_deg", "time_s",
    *ERROR_CHANNELS, *ENVIRONMENT, "not_still",
)
