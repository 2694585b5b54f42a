"""``python -m optimize``: the main job.

Until the tooth-profile optimizer lands this runs the foundation demo on the built-in
default (08B chain, 18-tooth sprocket).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from .demo import run


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(prog="python -m optimize", description=__doc__)
    ap.add_argument("--chain", default="08B", help="ISO 606 chain (default 08B)")
    ap.add_argument("--teeth", type=int, default=18, help="sprocket teeth (default 18)")
    ap.add_argument("--speed", type=float, default=0.5, help="seat impact speed [m/s]")
    ap.add_argument("--out", type=Path, default=Path("results/demo"), help="output folder")
    args = ap.parse_args(argv)
    try:
        run(args.out, args.chain, args.teeth, args.speed)
    except ValueError as e:
        ap.error(str(e))


if __name__ == "__main__":
    main()
