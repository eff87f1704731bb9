"""``guideway air-index``: refractive index of air from temperature, pressure and humidity."""

from __future__ import annotations

import argparse
import json
import sys


def run(args: argparse.Namespace) -> int:
    from saved_runs.evaluation.air import checked_air_index, equation_name

    result = checked_air_index(args.t_c, args.p_pa, args.rh, co2_ppm=args.co2_ppm,
                               wavelength_nm=args.wavelength_nm, equation=args.equation)
    n = result["n"]
    if args.json:
        json.dump(result, sys.stdout)
        sys.stdout.write("\n")
    else:
        print(f"n = {n!r}  ({equation_name(args.equation)}; t = {args.t_c:g} C, p = {args.p_pa:g} Pa, "
              f"RH = {args.rh:g} %, CO2 = {args.co2_ppm:g} ppm, vacuum wavelength {args.wavelength_nm:g} nm)")
    return 0


def register(sub) -> None:  # noqa: ANN001
    from saved_runs.evaluation.air import DEFAULT_CO2_PPM, DEFAULT_EQUATION, EQUATIONS, HENE_WAVELENGTH_NM

    pa = sub.add_parser("air-index", help="refractive index of air (modified Edlén or Ciddor)")
    pa.add_argument("--t-c", type=float, required=True, help="air temperature (C)")
    pa.add_argument("--p-pa", type=float, required=True, help="air pressure (Pa)")
    pa.add_argument("--rh", type=float, required=True, help="relative humidity (%%)")
    pa.add_argument("--co2-ppm", type=float, default=DEFAULT_CO2_PPM, help="CO2 content (ppm, default %(default)s)")
    pa.add_argument("--wavelength-nm", type=float, default=HENE_WAVELENGTH_NM,
                    help="vacuum wavelength (nm, default %(default)s, HeNe)")
    pa.add_argument("--equation", choices=EQUATIONS, default=DEFAULT_EQUATION,
                    help="edlen = modified Edlén (Birch & Downs 1994, NIST form), ciddor = Ciddor 1996 "
                         "(default %(default)s)")
    pa.add_argument("--json", action="store_true", help="print one JSON object {\"n\": ...}")
    pa.set_defaults(func=run)
