#!/usr/bin/env bash
# make bench: benchmarks measured in one run on this machine; writes docs/benchmarks.md.
set -eu
cd "$(dirname "$0")/.."
OMP_NUM_THREADS=${OMP_NUM_THREADS:-2} OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_dop853.py "$@"
