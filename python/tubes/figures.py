"""Every figure of a tubes result, e.g. the paper's: python -m tubes.figures paper.h5 [-o figures]

The same as python -m tubes.plots (which draws whatever the file has data for)."""
from .plots import main

if __name__ == "__main__":
    raise SystemExit(main())
