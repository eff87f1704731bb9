"""Physical bounds of fitted effects: a value no real set-up can have is flagged as implausible,
not named as found (docs/diagnosis.md).  The bounds are deliberately wide: they catch a fit that
has absorbed something else (an effect outside the library, another effect it cannot be told from),
not a poor set-up."""

from __future__ import annotations

import numpy as np

from ..effects import Effect
from .observations import Observations

MAX_GAIN_PPM = 1e5  # a 10 % scale error: a sensor tilted by 25°, or not the sensor recorded
MAX_ABBE_MM = 2000.0  # farther than a measuring line sits from any functional point
MAX_BLOCK_UM = 1000.0  # a block a millimetre longer than recorded would be seen with a ruler


def implausible(effect: Effect, obs: Observations) -> str:
    """Why the fitted ``effect`` is physically implausible on this run ('' when it is not)."""
    t = effect.type
    if t == "dead_path" and effect.value("length_mm") < 0:
        return f"a negative dead path ({effect.value('length_mm'):.4g} mm)"
    if t == "sensor_gain" and abs(effect.value("ppm")) > MAX_GAIN_PPM:
        return f"a sensor gain error of {effect.value('ppm') * 1e-4:+.3g} % (beyond ±{MAX_GAIN_PPM * 1e-4:g} %)"
    if t == "abbe" and abs(effect.value("offset_mm")) > MAX_ABBE_MM:
        return f"an Abbe offset of {effect.value('offset_mm'):.4g} mm (beyond ±{MAX_ABBE_MM:g} mm)"
    if t == "block_length" and abs(effect.value("um_per_block")) > MAX_BLOCK_UM:
        return f"a block {effect.value('um_per_block'):.4g} um off its recorded length (beyond ±{MAX_BLOCK_UM:g} um)"
    if t == "lever_arm" and "lever_x_mm" in obs.values:
        lever = float(np.abs(obs.values["lever_x_mm"][0]))
        if effect.value("error_mm") >= lever:
            return (f"a lever arm error of {effect.value('error_mm'):.4g} mm: the true P-Q distance would be "
                    f"{lever - effect.value('error_mm'):.4g} mm, not positive")
    return ""
