"""``python -m melange_ti.bench WHICH [options]``: the benchmarks with their finer options."""

import sys

from .cli import build_parser, main

sys.exit(main(build_parser().parse_args()))
