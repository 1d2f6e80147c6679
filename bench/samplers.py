"""The sampler study (issue: the seed's comparison samplers): the same code as `brdf-studio bench samplers`.

    .venv/bin/python bench/samplers.py [--quick] [--models phong ward ...] [--out results/samplers]

Prints a Markdown table and writes study.csv, study.md, error_vs_samples.png and error_vs_time.png.
"""

import sys

from app.cli import main

if __name__ == "__main__":
    sys.exit(main(["bench", "samplers", *sys.argv[1:]]))
