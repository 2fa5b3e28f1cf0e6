"""Error of an image against a reference EXR: RMSE, relative MSE and, given the render time,
efficiency = 1 / (MSE x seconds).

    python tools/compare.py image.exr reference.exr [--seconds 12.3]
"""
import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
import clrender  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("image", type=Path)
    parser.add_argument("reference", type=Path)
    parser.add_argument("--seconds", type=float, help="render time of the image, for efficiency")
    args = parser.parse_args()
    image, reference = clrender.load_image(args.image), clrender.load_image(args.reference)
    if image.shape != reference.shape:
        sys.exit(f"shape mismatch: {image.shape} vs {reference.shape}")
    mse = clrender.mse(image, reference)
    print(f"RMSE          {clrender.rmse(image, reference):.6g}")
    print(f"relative MSE  {clrender.relative_mse(image, reference):.6g}")
    if args.seconds:
        print(f"efficiency    {clrender.efficiency(mse, args.seconds):.6g}  (1 / (MSE x s))")


if __name__ == "__main__":
    main()
