#!/usr/bin/env bash
# The MPI flavour's checks (make check runs them through tests/run_all.sh when build/mpi/bin/tubes
# exists). usage: tests/mpi_check.sh identical|fault|badinput|badoutput|pastend|flux3|formula|taylor|damped
#   identical  the serial ./tubes (1 thread) and the MPI build with 1 rank x 2 threads, 2 ranks x
#              1 thread and 2 ranks x 2 threads write the same file, bit for bit
#              (python -m tubes.h5compare: every dataset and attribute but the provenance ones)
#   fault      a work item that fails on rank 1 (TUBES_FAULT) is reported by rank 0 with its
#              diagnostics, the run ends (exit 2) without hanging, and the file records it
#   badinput   a bad namelist: one message (not one per rank), exit 1, no file
#   badoutput  an output file that cannot be created: exit 3 on every rank, no hang
#   pastend    a transition energy past the family's end, dealt to rank 1, with multiple shooting:
#              rank 1 says where the family ends (the serial run's message), exit 4, no hang
#   flux3      the 3-DOF flux scene (flux samples, section points, tube seeds shared out): 2 ranks
#              x 2 threads write the serial run's file, bit for bit
#   formula    a model written as a formula, new to an empty cache: 2 ranks build it at once and
#              write the serial run's file, bit for bit; the cache holds the serial run's whole libraries only
#   taylor     method = 'taylor' (lanes for the tube seeds, Monte Carlo points and Poincare seeds),
#              its kernels new to an empty cache: 2 ranks x 2 threads write the serial run's file
#   damped     the dissipative scenes (viscous: threshold search, regions, Monte Carlo; rolling
#              resistance: stalls; noise: the Monte Carlo's streams): 2 ranks x 2 threads write the
#              serial run's file, bit for bit
set -u
cd "$(dirname "$0")/.."
root=$PWD
bin=$root/build/mpi/bin/tubes
py=$root/.venv/bin/python
[ -x "$bin" ] || { echo "FAIL: no MPI build at $bin"; exit 1; }
# OpenMPI refuses root and more ranks than cores unless told (toolchain-notes pitfall 10);
# --bind-to none lets each rank's OpenMP threads use every core. MPICH's mpiexec needs none.
if mpirun --version 2>&1 | grep -q "Open MPI"; then
  launch=(mpirun --allow-run-as-root --oversubscribe --bind-to none -x OMP_NUM_THREADS -x TUBES_FAULT)
else
  launch=(mpiexec -genvlist OMP_NUM_THREADS,TUBES_FAULT)
fi
export TUBES_FAULT=
work=$(mktemp -d)
trap '[ -n "${KEEP:-}" ] || rm -rf "$work"' EXIT
fail=0
check() {   # check CONDITION-EXIT-CODE MESSAGE
  if [ "$1" -eq 0 ]; then echo "ok: $2"; else echo "FAIL: $2"; fail=1; fi
}
# run_serial DIR NML CACHE MESSAGE: ./tubes (1 thread) on $work/NML in $work/DIR, its model cache
# $work/CACHE; run_mpi DIR NML CACHE THREADS MESSAGE: the MPI build, 2 ranks x THREADS threads
run_serial() {
  mkdir -p "$work/$1"
  (cd "$work/$1" && TUBES_CACHE_DIR="$work/$3" OMP_NUM_THREADS=1 timeout 600 "$root/tubes" "../$2" >log 2>&1)
  check $? "$4"
}
run_mpi() {
  mkdir -p "$work/$1"
  (cd "$work/$1" && TUBES_CACHE_DIR="$work/$3" OMP_NUM_THREADS=$4 timeout 600 "${launch[@]}" -np 2 "$bin" "../$2" \
    >log 2>&1)
  check $? "$5"
}
# same_output DIR1 DIR2 MESSAGE: their out.h5 are identical (h5compare, the provenance aside)
same_output() {
  "$py" -m tubes.h5compare "$work/$1/out.h5" "$work/$2/out.h5" --ignore git_commit
  check $? "$3"
}
# Every distributed loop: tube seeds with adaptive refinement (tubes, montecarlo), whole energies
# (transition: dE = 300 is rank 1's), Monte Carlo samples, Poincare seeds, multiple-shooting
# segments, synthetic tracks.
cat >"$work/all.nml" <<'EOF'
&run
  scenes = 'orbits', 'tubes', 'transition', 'montecarlo', 'sections', 'synthetic_experiment'
  output = 'out.h5'
/
&orbits
  saddle = 'S12', de = 10, 100, method = 'multiple', n_segments = 6
/
&tubes
  de = 100, kind = 'both', area_tol = 1e-8, n_max = 1024
/
&transition
  de = 20, 300, area_tol = 1e-6
/
&montecarlo
  de = 100, n_samples = 301, seed = 11
/
&sections
  de = 100, n_seeds = 7, n_iter = 15
/
&experiment
  n_tracks = 9, duration = 3.0, damping_ratio = 0.01, seed = 5
/
EOF

case "${1:-}" in
identical)
  mkdir -p "$work/serial" "$work/r1t2" "$work/r2t1" "$work/r2t2"
  (cd "$work/serial" && OMP_NUM_THREADS=1 timeout 300 "$root/tubes" ../all.nml >log 2>&1)
  check $? "serial run"
  (cd "$work/r1t2" && OMP_NUM_THREADS=2 timeout 300 "${launch[@]}" -np 1 "$bin" ../all.nml >log 2>&1)
  check $? "MPI 1 rank x 2 threads"
  (cd "$work/r2t1" && OMP_NUM_THREADS=1 timeout 300 "${launch[@]}" -np 2 "$bin" ../all.nml >log 2>&1)
  check $? "MPI 2 ranks x 1 thread"
  (cd "$work/r2t2" && OMP_NUM_THREADS=2 timeout 300 "${launch[@]}" -np 2 "$bin" ../all.nml >log 2>&1)
  check $? "MPI 2 ranks x 2 threads"
  for d in r1t2 r2t1 r2t2; do
    # git_commit is the build's provenance: the two flavours are two builds, and a tree edited
    # between them (dirty or not) differs there without a different result
    "$py" -m tubes.h5compare "$work/serial/out.h5" "$work/$d/out.h5" --ignore git_commit
    check $? "$d identical to the serial run"
  done
  "$py" - "$work/r2t2/out.h5" <<'EOF'
import sys, h5py
f = h5py.File(sys.argv[1], "r")
assert int(f.attrs["mpi_ranks"]) == 2 and int(f.attrs["omp_threads"]) == 2, dict(f.attrs)
assert int(f.attrs["exit_status"]) == 0
EOF
  check $? "provenance records 2 ranks x 2 threads"
  n=$(grep -c "^wrote" "$work/r2t2/log")
  [ "$n" -eq 1 ]
  check $? "only rank 0 prints (\"wrote\" appears $n time(s))"
  ;;
fault)
  for f in sample:2 seed:4; do
    mkdir -p "$work/$f"
    (cd "$work/$f" && TUBES_FAULT=$f OMP_NUM_THREADS=1 timeout 120 "${launch[@]}" -np 2 "$bin" ../all.nml \
      >log 2>err)
    rc=$?
    [ "$rc" -eq 2 ]
    check $? "TUBES_FAULT=$f (an item of rank 1): exit 2 (got $rc; 124 = hung)"
    grep -q "failure injected by TUBES_FAULT" "$work/$f/err"
    check $? "TUBES_FAULT=$f: reported on stderr"
    ls "$work/$f"/*.tmp.* >/dev/null 2>&1
    [ $? -ne 0 ]
    check $? "TUBES_FAULT=$f: no temporary file left"
    "$py" -c "import h5py, sys; sys.exit(int(h5py.File('$work/$f/out.h5')['/'].attrs['exit_status']) != 2)"
    check $? "TUBES_FAULT=$f: the file is written and records exit status 2"
  done
  grep -q "sample 2 at (r, p_r)" "$work/sample:2/err"
  check $? "the failed sample is named with its point"
  grep -q "seed(s) failed, the first at orbit phase" "$work/seed:4/err"
  check $? "the failed seed is named with its phase"
  grep -q "the cut at dE = 300 failed" "$work/seed:4/err"
  check $? "a failure in an energy computed by rank 1 (transition) is reported by rank 0"
  ;;
badinput)
  printf '&run\n  scenes = "tubes"\n  output = "x.h5"\n/\n&tubes\n  de = -5\n/\n' >"$work/bad.nml"
  (cd "$work" && OMP_NUM_THREADS=1 timeout 60 "${launch[@]}" -np 2 "$bin" bad.nml >log 2>err)
  rc=$?
  [ "$rc" -eq 1 ]
  check $? "bad input: exit 1 (got $rc)"
  n=$(grep -c "bad.nml" "$work/err")
  [ "$n" -eq 1 ]
  check $? "bad input: one message naming the file (found $n)"
  [ ! -e "$work/x.h5" ]
  check $? "bad input: no output file"
  ;;
pastend)
  # the message continues the family on the rank that was dealt the energy, alone: before, that
  # rank waited for the others in the multiple-shooting corrector (a hang)
  printf "&run scenes = 'transition', output = 'p.h5' /\n&orbits saddle = 'S12', method = 'multiple', n_segments = 4 /\n&transition de = 100, 790, area_tol = 1e-6 /\n" \
    >"$work/past.nml"
  (cd "$work" && OMP_NUM_THREADS=1 timeout 120 "${launch[@]}" -np 2 "$bin" past.nml >log 2>err)
  rc=$?
  [ "$rc" -eq 4 ]
  check $? "an energy past the family's end on rank 1: exit 4 (got $rc; 124 = hung)"
  grep -q "dE = 790 is past the end of the S12 family, which ends at dE ~ 777.06" "$work/err"
  check $? "where the family ends is reported"
  ;;
badoutput)
  (cd "$work" && OMP_NUM_THREADS=1 timeout 60 "${launch[@]}" -np 2 "$bin" all.nml -o "$work/no/such/dir/x.h5" \
    >log 2>err)
  rc=$?
  [ "$rc" -eq 3 ]
  check $? "an output file that cannot be created: exit 3 (got $rc; 124 = hung)"
  grep -q "cannot create output file" "$work/err"
  check $? "the reason is reported"
  ;;
formula)
  sed -e "s/^&run\$/\&model system = 'expression', hamiltonian = '(px^2 + py^2)\/2 - x^2\/2 + x^4\/4 + w^2*y^2\/2 + c*x^2*y', constants = 'w = 1.5', 'c = 0.2' \/\n\&equilibria box = 2 \/\n\&section kind = 'plane', index = 1, value = 0.5, direction = -1 \/\n\&run/" \
      -e "s/saddle = 'S12', de = 10, 100/saddle_near = 0, 0, de = 0.01, 0.05/" -e "s/de = 100, kind = 'both'/de = 0.05, kind = 'stable'/" \
      -e "s/de = 20, 300/de = 0.02, 0.1/" -e "s/de = 100, n_samples/de = 0.05, n_samples/" \
      -e "s/de = 100, n_seeds/de = 0.05, n_seeds/" -e "s/, 'synthetic_experiment'//" "$work/all.nml" >"$work/f.nml"
  run_serial fs f.nml cs "serial run of a formula's model"
  run_mpi fm f.nml cm 1 "MPI 2 ranks x 1 thread, building the model in an empty cache at once"
  same_output fs fm "the formula's MPI run is identical to the serial run"
  # the model's library and its Taylor kernels (method 'auto'): the ranks' cache holds as many
  # whole libraries as the serial run's (their names differ: the MPI build's compiler is hashed
  # in), and nothing else (no lock, source or partial file)
  [ "$(ls "$work/cm")" = "$(cd "$work/cm" && ls expr_*.so expr_*.so.sha256)" ] && [ "$(ls "$work/cm" | wc -l)" -eq "$(ls "$work/cs" | wc -l)" ]
  check $? "the cache holds as many whole libraries as the serial run's, and no leftovers ($(ls "$work/cm" | tr '\n' ' '))"
  ;;
flux3)
  # the 3-DOF flux scene: dividing-surface samples, section points and tube seeds dealt out
  cat >"$work/f3.nml" <<'EOF'
&run scenes = 'flux', output = 'out.h5' /
&model system = 'expression', hamiltonian = '(p1^2 + p2^2 + p3^2)/2 - q1^2/2 + q1^4/4 + 1.3^2*q2^2/2 + 2.1^2*q3^2/2 + 0.3*q2^2*q3^2',
  coordinates = 'q1', 'q2', 'q3', momenta = 'p1', 'p2', 'p3' /
&equilibria box = 1.0, n_grid = 5 /
&orbits saddle_near = 0, 0, 0 /
&section kind = 'plane', index = 1, value = -0.7, direction = 1 /
&flux de = 0.05, order = 6, n_samples = 3001, n_cut = 8 /
EOF
  run_serial 3s f3.nml c3 "serial run of the 3-DOF flux scene"
  run_mpi 3m f3.nml c3 2 "MPI 2 ranks x 2 threads"
  same_output 3s 3m "the 3-DOF flux scene (samples, section, tube cut) is identical on 2 ranks"
  ;;
taylor)
  # the Taylor method's lanes (tube seeds, Monte Carlo points, Poincare seeds) and its kernels
  # built at once by 2 ranks into an empty cache: 2 ranks x 2 threads write the serial run's file
  cat >"$work/ty.nml" <<'EOF'
&run scenes = 'orbits', 'tubes', 'transition', 'montecarlo', 'sections', output = 'out.h5' /
&integrator method = 'taylor', rtol = 1e-10, atol = 1e-10 /
&orbits saddle = 'S12', de = 10, 100, rtol = 1e-10, atol = 1e-10 /
&tubes de = 100, kind = 'both', area_tol = 1e-8, n_max = 1024 /
&transition de = 20, 300, area_tol = 1e-6 /
&montecarlo de = 100, n_samples = 301, seed = 11 /
&sections de = 100, n_seeds = 7, n_iter = 15 /
EOF
  run_mpi tm ty.nml ct 2 "MPI 2 ranks x 2 threads, Taylor, kernels new to the cache"
  run_serial ts ty.nml ct "serial run, Taylor"
  same_output ts tm "Taylor: 2 ranks x 2 threads identical to the serial run"
  ;;
damped)
  # the dissipative scenes: viscous damping (an empty energy whose threshold search runs on
  # rank 0 while rank 1 traces a region; the region's scan shared out; Monte Carlo points) and
  # rolling resistance (stalls, trapped points): 2 ranks x 2 threads write the serial run's file
  cat >"$work/dv.nml" <<'EOF'
&run scenes = 'tubes', 'transition', 'montecarlo', output = 'out.h5' /
&model damping_ratio = 0.025 /
&tubes de = 100 /
&transition de = 50, 300, area_tol = 1e-6 /
&montecarlo de = 300, n_samples = 301, seed = 11 /
EOF
  sed -e "s/damping_ratio = 0.025/rolling_resistance = 0.013/" -e "s/de = 50, 300/de = 60, 100/" \
      -e "s/de = 300, n_samples/de = 100, n_samples/" "$work/dv.nml" >"$work/dr.nml"
  # noise: each Monte Carlo point's own Philox stream, whichever rank and thread integrates it
  printf "&run scenes = 'montecarlo', output = 'out.h5' /\n&model damping_ratio = 0.014, noise = 100 /\n&montecarlo de = 100, n_samples = 301, seed = 11 /\n" \
    >"$work/dn.nml"
  # one model cache for the three (building kernels is not what this checks: formula and taylor do)
  for k in dv dr dn; do
    run_serial ${k}s $k.nml cd "serial run, $k"
    run_mpi ${k}m $k.nml cd 2 "MPI 2 ranks x 2 threads, $k"
    same_output ${k}s ${k}m "$k (dissipative scenes): 2 ranks x 2 threads identical to the serial run"
  done
  ;;
*)
  echo "usage: tests/mpi_check.sh identical|fault|badinput|badoutput|pastend|formula|flux3|taylor|damped" >&2
  exit 2
  ;;
esac
exit $fail
