#!/usr/bin/env bash
# make bench: benchmarks measured in one run on this machine; results into docs/benchmarks.md and
# charts into docs/. Installs the bench-only peer heyoka into .venv when missing.
set -eu
cd "$(dirname "$0")/.."
if ! .venv/bin/python -c 'import heyoka' 2>/dev/null; then
  echo "bench: installing heyoka (bench-only) into .venv"
  .venv/bin/pip install --quiet heyoka
fi
export OPENBLAS_NUM_THREADS=1
OMP_NUM_THREADS=${OMP_NUM_THREADS:-2} .venv/bin/python bench/bench_dop853.py
OMP_NUM_THREADS=${OMP_NUM_THREADS:-2} .venv/bin/python bench/bench_integrators.py
.venv/bin/python bench/bench_tubes.py
.venv/bin/python bench/bench_expression.py
if [ -f bench/bench_stability.py ]; then .venv/bin/python bench/bench_stability.py; fi
.venv/bin/python bench/bench_taylor.py
.venv/bin/python bench/bench_percall.py
# ensembles in lanes against heyoka's batch mode and the lone integrator (issue 36; printed, the
# tables in docs/benchmarks.md "Ensembles of 64 distinct starts" are copied from it by hand)
.venv/bin/python bench/bench_lanes.py 7
OMP_NUM_THREADS=${OMP_NUM_THREADS:-2} .venv/bin/python bench/bench_paper_method.py
# the Monte Carlo against the commit issue 36 was filed on (built once in build/bench-base)
.venv/bin/python bench/bench_mc_base.py
# the MPI flavour's scaling (docs/cluster.md), when an MPI compiler wrapper is installed
if command -v mpifort >/dev/null 2>&1; then
  make --no-print-directory MPI=1 build/mpi/bin/tubes
  .venv/bin/python bench/bench_mpi.py
fi
echo "bench: results in docs/benchmarks.md"
