# tubes: one Makefile. `make deps`, `make`, `make check`, `make bench`, `make lint`, `make clean`.
# Release objects go to build/, the runtime-checked variant used by `make check` to build/debug/.

# Parallel by default: as many jobs as the machine has processors (at most 8), unless -j is given
# (make -j1 for a serial build). The module order comes from the sources' use lines (race-free).
ifeq ($(filter -j%,$(MAKEFLAGS)),)
MAKEFLAGS += -j$(shell n=$$(nproc 2>/dev/null || echo 1); [ "$$n" -gt 8 ] && n=8; echo $$n)
endif

# MPI=1: the MPI flavour (docs/cluster.md), built with the MPI compiler wrappers into build/mpi;
# `./tubes` is a copy of the flavour built last (`make` and `make MPI=1` each restore their own).
ifeq ($(MPI),1)
FC       := $(or $(MPIFC),mpifort)
CC       := $(or $(MPICC),mpicc)
BUILD    ?= build/mpi
MPI_DEF  := -DTUBES_MPI
else
MPI_DEF  :=
endif

# GNU make's built-in FC is f77 (toolchain-notes pitfall 8): only honour FC if the user set it.
ifeq ($(origin FC),default)
FC := gfortran
endif
ifeq ($(origin CC),default)
CC := gcc
endif

PREFIX   ?= /usr/local
BUILD    ?= build
MODE     ?= release
PYTHON   ?= /usr/bin/python3
VENV     := .venv
VPY      := $(abspath $(VENV))/bin/python

VERSION  := 0.1.0
GIT_HASH := $(shell git rev-parse --short=12 HEAD 2>/dev/null || echo unknown)$(shell git diff --quiet HEAD 2>/dev/null || echo -dirty)

HDF5_CFLAGS := $(shell pkg-config --cflags hdf5-serial 2>/dev/null)
HDF5_LIBS   := $(shell pkg-config --libs hdf5-serial 2>/dev/null) -lhdf5_hl
LAPACK_LIBS := -llapack -lblas
GSL_LIBS    := -lgsl -lgslcblas
SUNDIALS_INC := -I/usr/include/sundials/fortran
SUNDIALS_LIBS := -lsundials_fcvode_mod -lsundials_cvode -lsundials_farkode_mod -lsundials_arkode
FFTW_INC  := -I/usr/include
FFTW_LIBS := -lfftw3

ifeq ($(MODE),debug)
OPT_F := -O0 -g -fcheck=all -ffpe-trap=invalid,zero,overflow -fbacktrace
OPT_C := -O0 -g
else ifeq ($(MODE),sanitize)
SAN   := -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined
OPT_F := -O1 -g -fcheck=all $(SAN)
OPT_C := -O1 -g $(SAN)
else
OPT_F := -O2 -g
OPT_C := -O2 -g
endif
FFLAGS_ALL := -std=f2018 -fPIC -fopenmp -Wall -Wno-unused-dummy-argument -Wno-compare-reals \
              -Wno-maybe-uninitialized $(OPT_F) -J $(BUILD)/mod -I $(BUILD)/mod $(SUNDIALS_INC) $(FFTW_INC) $(FFLAGS)
CFLAGS_ALL := -std=c11 -D_POSIX_C_SOURCE=200809L -fPIC -fopenmp -Wall -Wextra $(OPT_C) -Iinclude -I$(BUILD)/include \
              $(HDF5_CFLAGS) -DTUBES_VERSION='"$(VERSION)"' -DTUBES_GIT='"$(GIT_HASH)"' \
              -DTUBES_COMPILER='"$(FC) $(shell $(FC) -dumpfullversion 2>/dev/null)"' \
              -DTUBES_FFLAGS='"$(strip $(OPT_F))"' $(MPI_DEF) $(CFLAGS)
# WERROR=1 (.ci/run): a warning of the compilers fails the build of the project's own sources
ifeq ($(WERROR),1)
FFLAGS_ALL += -Werror
CFLAGS_ALL += -Werror
endif
LDLIBS_ALL := $(HDF5_LIBS) $(SUNDIALS_LIBS) $(GSL_LIBS) $(FFTW_LIBS) $(LAPACK_LIBS) -lm $(LDLIBS)

# src/ in topic folders (docs/development.md): base, models, integrators, orbits, transport,
# experiment, parallel, workflow, capi (the C API), io (the C driver, namelist and HDF5)
SRC_DIRS := $(sort $(dir $(wildcard src/*/)))
FFLAGS_ALL += $(addprefix -I,$(SRC_DIRS))   # the kind-generic sources' include lines
F_SRC := $(wildcard $(addsuffix *.f90,$(SRC_DIRS)))
CONFIG_H := $(BUILD)/include/tubes_config_fields.h
REGISTRY_H := $(BUILD)/include/tubes_registry.h
C_SRC := $(filter-out src/io/tubes_main.c,$(wildcard $(addsuffix *.c,$(SRC_DIRS))))
F_OBJ := $(patsubst %.f90,$(BUILD)/obj/%.o,$(notdir $(F_SRC)))
C_OBJ := $(patsubst %.c,$(BUILD)/obj/%.o,$(notdir $(C_SRC)))
LIB   := $(BUILD)/libtubes.a
vpath %.f90 $(SRC_DIRS) tests
vpath %.c $(SRC_DIRS) tests

T_F_SRC := $(wildcard tests/test_*.f90)
T_C_SRC := $(wildcard tests/test_*.c)
T_BIN   := $(patsubst tests/%.f90,$(BUILD)/tests/%,$(T_F_SRC)) $(patsubst tests/%.c,$(BUILD)/tests/%,$(T_C_SRC))

PYEXT_STAMP := $(BUILD)/pyext.stamp

.PHONY: wheel-products print-version venv-link all deps check quick tests lint bench docs clean install python paper fuzz sanitize pipcheck FORCE
ifeq ($(MPI),1)
all: tubes $(LIB)           # the Python extension is built by the serial flavour only
else
all: tubes $(LIB) python venv-link
endif

# ---------------------------------------------------------------- dependencies
APT_PKGS := gfortran gcc make pkg-config libhdf5-dev liblapack-dev libgsl-dev libsundials-dev \
            libsundials-fortran-dev libfftw3-dev libopenmpi-dev openmpi-bin python3-dev python3-venv \
            clang-14 libclang-rt-14-dev
# the venv's packages as module:package, checked by importability; what is missing is installed.
# atheris (Python fuzz targets, make fuzz) is optional: if pip cannot get it, those targets SKIP.
PY_MODS  := numpy:numpy scipy:scipy h5py:h5py matplotlib:matplotlib pytest:pytest xdist:pytest-xdist \
            mesonbuild:meson ninja:ninja pandas:pandas xarray:xarray hypothesis:hypothesis sympy:sympy
PY_PKGS  := $(foreach m,$(PY_MODS),$(lastword $(subst :, ,$(m))))
PY_FUZZ_PKGS := atheris==3.0.0
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)
deps:
	@missing=$$(for p in $(APT_PKGS); do dpkg-query -W -f='$${Status}\n' $$p 2>/dev/null \
	    | grep -q 'install ok installed' || echo $$p; done); \
	if [ -n "$$missing" ]; then \
	  echo "deps: installing Debian packages:" $$missing; \
	  $(SUDO) apt-get update -qq && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq \
	    --no-install-recommends $$missing || exit 1; \
	else echo "deps: Debian packages already installed"; fi
	@if ! $(VENV)/bin/python -c '' 2>/dev/null; then echo "deps: creating $(VENV)"; \
	  $(PYTHON) -m venv --clear $(VENV) && $(VENV)/bin/python -m pip install --quiet --upgrade pip || exit 1; fi
	@missing=$$($(VENV)/bin/python -c 'import importlib.util as u, sys; \
	    print(*[p for m, p in (a.split(":") for a in sys.argv[1:]) if u.find_spec(m) is None])' $(PY_MODS)); \
	if [ -z "$$missing" ] && [ -x $(VENV)/bin/ninja ]; then echo "deps: $(VENV) already complete"; \
	else echo "deps: installing into $(VENV):" $${missing:-ninja}; \
	  $(VENV)/bin/python -m pip install --quiet $${missing:-ninja} || exit 1; fi
	@$(VENV)/bin/python -c 'import importlib.util as u; assert u.find_spec("atheris")' 2>/dev/null \
	  || $(VENV)/bin/python -m pip install --quiet $(PY_FUZZ_PKGS) \
	  || echo "deps: pip could not install $(PY_FUZZ_PKGS): the Python fuzz targets will SKIP (make fuzz, make check)"
	@$(MAKE) --no-print-directory venv-link

# The .venv finds this tree's python/ through tubes-dev.pth, a path relative to its site-packages
# (site.py joins them), so a copied tree (cp -r) imports its own package, not the original's.
# `make` checks it each time and re-points a .venv made before this rule (an absolute path).
venv-link:
	@[ -x $(VENV)/bin/python ] || exit 0; \
	site=$$($(VENV)/bin/python -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])') && \
	rel=$$($(VENV)/bin/python -c 'import os, sys; print(os.path.relpath(sys.argv[1], sys.argv[2]))' \
	  "$(abspath python)" "$$site") && \
	if [ "$$(cat $$site/tubes-dev.pth 2>/dev/null)" != "$$rel" ]; then \
	  echo "$$rel" > $$site/tubes-dev.pth && echo "venv-link: $(VENV) imports tubes from $(abspath python)"; fi

# ---------------------------------------------------------------- build
$(BUILD)/obj $(BUILD)/mod $(BUILD)/tests:
	@mkdir -p $@

# Module order from the `use tubes_*` lines (file name = module name, STYLE.md); the kind-generic
# sources (src/*/*.inc, docs/development.md) from the `include '...'` lines.
$(BUILD)/deps.mk: $(F_SRC) $(T_F_SRC) Makefile | $(BUILD)/obj
	@for f in $(F_SRC) $(T_F_SRC); do b=$$(basename $$f .f90); \
	  for m in $$(sed -n 's/^ *use  *\(tubes_[a-z0-9_]*\).*/\1/p' $$f | sort -u); do \
	    [ "$$m" = "$$b" ] || echo "$(BUILD)/obj/$$b.o: $(BUILD)/obj/$$m.o"; done; \
	  for i in $$(sed -n "s/^ *include  *'\([a-z0-9_]*\.inc\)'.*/\1/p" $$f | sort -u); do \
	    case $$i in nml_*) ;; *) echo "$(BUILD)/obj/$$b.o: $$(ls src/*/$$i)";; esac; done; done > $@
-include $(BUILD)/deps.mk

$(BUILD)/obj/%.o: %.f90 | $(BUILD)/obj $(BUILD)/mod
	$(FC) $(FFLAGS_ALL) -c $< -o $@
# The integrators' and models' automatic arrays and array temporaries, all sized by the state (a
# few dozen numbers), on the stack: a heap allocation per step and per stage cost 13 % of the
# paper's run (docs/benchmarks.md). Elsewhere arrays can be large (ensembles, tracks): the heap.
STACK_OBJ := $(patsubst %.f90,$(BUILD)/obj/%.o,$(notdir $(wildcard src/integrators/*.f90 src/models/*.f90)))
$(STACK_OBJ): private FFLAGS_ALL += -fstack-arrays
# The lanes' driver (src/integrators/tubes_lanes_run.f90, a submodule of tubes_lanes) is built three
# times: with the library's flags (for any processor of its architecture: SSE2's two doubles a
# vector on x86-64), and as the submodules tubes_lanes_run_v3 (-march=x86-64-v3: AVX2, four) and
# tubes_lanes_run_v4 (-march=x86-64-v4: AVX-512, eight); tubes_lanes runs the widest the processor
# has (tubes_lanes_driver, src/io/tubes_expr.c). -ffp-contract=off: no multiply-add the library's
# build lacks, so every build's numbers are the lone integrator's, bit for bit (tests/test_lanes).
# On another architecture the three are the same code, and the first is the one run.
LANES_RUN_V := $(BUILD)/obj/tubes_lanes_run_v3.o $(BUILD)/obj/tubes_lanes_run_v4.o
ifneq ($(filter x86_64-%,$(shell $(FC) -dumpmachine)),)
LANES_MARCH_3 := -march=x86-64-v3
LANES_MARCH_4 := -march=x86-64-v4 -mprefer-vector-width=512
endif
$(BUILD)/obj/tubes_lanes_run.o: $(BUILD)/obj/tubes_lanes.o
$(BUILD)/obj/tubes_lanes_run.o: private FFLAGS_ALL += -cpp
$(BUILD)/obj/tubes_lanes_run_v%.o: src/integrators/tubes_lanes_run.f90 $(BUILD)/obj/tubes_lanes_run.o
	$(FC) $(FFLAGS_ALL) -fstack-arrays -cpp -DTUBES_LANES_V=$* -ffp-contract=off $(LANES_MARCH_$*) -c $< -o $@
# The integrators' module procedures inlined within their file (-fPIC alone makes each a symbol
# that could be replaced at link time, never inlined): the Taylor method's step size in the lanes'
# loop, which then vectorises (src/integrators/tubes_step_size.inc).
INTEGRATOR_OBJ := $(patsubst %.f90,$(BUILD)/obj/%.o,$(notdir $(wildcard src/integrators/*.f90)))
$(INTEGRATOR_OBJ) $(LANES_RUN_V): private FFLAGS_ALL += -fno-semantic-interposition
# tubes_par is the one preprocessed source: MPI or the one-rank identity (src/parallel/tubes_par.f90)
$(BUILD)/obj/tubes_par.o: FFLAGS_ALL += -cpp $(MPI_DEF)
$(BUILD)/obj/%.o: %.c $(wildcard include/*.h) $(CONFIG_H) $(REGISTRY_H) | $(BUILD)/obj
	$(CC) $(CFLAGS_ALL) -c $< -o $@
# C's tubes_config_t, generated from its one definition in src/workflow/tubes_config.f90 (include/tubes_config.h)
$(CONFIG_H): src/workflow/tubes_config.f90 src/io/tubes_config_gen.awk
	@mkdir -p $(@D)
	awk -f src/io/tubes_config_gen.awk src/workflow/tubes_config.f90 > $@.tmp && mv $@.tmp $@
# The registered namelist variables (the annotated fields of src/workflow/tubes_config.f90): the reader's
# table rows and range checks (C) and the namelist's variables and copies (Fortran include files of
# src/io/tubes_nml.f90), all written by one run (src/io/tubes_registry_gen.awk; docs/development.md)
$(REGISTRY_H): src/workflow/tubes_config.f90 src/io/tubes_registry_gen.awk
	@mkdir -p $(@D)
	awk -v dir=$(@D) -f src/io/tubes_registry_gen.awk src/workflow/tubes_config.f90
$(BUILD)/obj/tubes_nml.o: $(REGISTRY_H)
$(BUILD)/obj/tubes_nml.o: FFLAGS_ALL += -I$(BUILD)/include
$(BUILD)/obj/tubes_setup.o: $(REGISTRY_H)   # the per-model defaults' rule (nml_defaults.inc)
$(BUILD)/obj/tubes_setup.o: FFLAGS_ALL += -I$(BUILD)/include

# The commit recorded in every output file: tubes_main.o is rebuilt whenever it changes (a commit,
# or the tree turning dirty or clean), not only when tubes_main.c does.
$(BUILD)/git_commit.txt: FORCE | $(BUILD)/obj
	@echo '$(GIT_HASH)' | cmp -s - $@ || echo '$(GIT_HASH)' > $@
$(BUILD)/obj/tubes_main.o: $(BUILD)/git_commit.txt
# models written as formulas are compiled by the build's C compiler (src/io/tubes_expr.c); the MPI
# flavour's is the compiler under its wrapper (OpenMPI's --showme, MPICH's -show): the kernels are
# plain C, so both flavours name them alike and share a model cache
MODEL_CC := $(if $(MPI_DEF),$(or $(firstword $(shell $(CC) --showme:command 2>/dev/null || $(CC) -show 2>/dev/null)),$(CC)),$(CC))
$(BUILD)/obj/tubes_expr.o: CFLAGS_ALL += -DTUBES_MODEL_CC='"$(MODEL_CC)"' -DTUBES_SOURCE_DIR='"$(abspath .)"' \
  -DTUBES_MODEL_CC_VERSION='"$(shell $(MODEL_CC) -dumpfullversion 2>/dev/null)"'

$(LIB): $(F_OBJ) $(LANES_RUN_V) $(C_OBJ)
	@rm -f $@
	ar rcs $@ $^

$(BUILD)/bin/tubes: $(BUILD)/obj/tubes_main.o $(LIB)
	@mkdir -p $(BUILD)/bin
	$(FC) -fopenmp $(SAN) -o $@ $^ $(LDLIBS_ALL)
# (copied, then renamed over ./tubes: a run of the old one keeps its file, no 'Text file busy')
tubes: $(BUILD)/bin/tubes FORCE
	@cmp -s $< $@ || { cp $< $@.new && mv -f $@.new $@ && echo "tubes: the $(if $(MPI_DEF),MPI,serial) flavour ($<)"; }

# ---------------------------------------------------------------- python extension (f2py, meson)
# PYEXT_PYTHON: the Python (with numpy, meson and ninja) that builds the extension, and whose
# version it is for: the project's .venv, or pip's build environment (`pip install .`, below).
PYEXT_PYTHON ?= $(VPY)
PYEXT_BUILT  := $(BUILD)/py/built.stamp
python: $(PYEXT_STAMP)
$(PYEXT_STAMP): $(PYEXT_BUILT)
	@rm -f python/tubes/_core*.so
	cp $(BUILD)/py/_core*.so python/tubes/
	@touch $@
# (MAKEFLAGS= : f2py's ninja, handed make's jobserver, warns "Jobserver 'pipe' mode detected")
$(PYEXT_BUILT): python/tubes_f2py.f90 $(LIB)
	@if [ ! -x $(PYEXT_PYTHON) ]; then echo "python: no $(PYEXT_PYTHON); run 'make deps' first" >&2; exit 1; fi
	@rm -rf $(BUILD)/py && mkdir -p $(BUILD)/py   # meson does not track .mod files: start clean
	cd $(BUILD)/py && MAKEFLAGS= PATH=$(dir $(PYEXT_PYTHON)):$$PATH FFLAGS="-fPIC -fopenmp" \
	  $(PYEXT_PYTHON) -m numpy.f2py -c --backend meson -m _core $(abspath python/tubes_f2py.f90) \
	  -I$(abspath $(BUILD)/mod) -L$(abspath $(BUILD)) -ltubes $(SUNDIALS_LIBS) $(GSL_LIBS) $(FFTW_LIBS) -llapack -lblas --dep openmp > f2py.log 2>&1 \
	  || { tail -30 f2py.log; exit 1; }
	@touch $@

# ---------------------------------------------------------------- pip install . (docs/development.md)
# pyproject.toml names meson-python; meson.build runs this target, which builds the serial
# flavour's executable and the extension into BUILD and copies them to WHEEL_DIR, whence meson
# installs them into the wheel's tubes/ (the executable as tubes/bin/tubes, run by the `tubes`
# console script, python/tubes/_program.py). The source lists and flags stay here, in one place.
WHEEL_DIR ?= $(BUILD)/wheel
wheel-products: $(BUILD)/bin/tubes $(PYEXT_BUILT)
	@mkdir -p $(WHEEL_DIR)
	cp $(BUILD)/bin/tubes $(WHEEL_DIR)/tubes
	cp $(BUILD)/py/_core*.so $(WHEEL_DIR)/
print-version:
	@echo $(VERSION)

# ---------------------------------------------------------------- tests
T_HELPERS := $(BUILD)/obj/tubes_check.o $(BUILD)/obj/tubes_test_models.o
$(BUILD)/tests/%: tests/%.f90 $(T_HELPERS) $(LIB) | $(BUILD)/tests
	$(FC) $(FFLAGS_ALL) -o $@ $< $(T_HELPERS) $(LIB) $(LDLIBS_ALL)
$(BUILD)/tests/%: tests/%.c $(LIB) | $(BUILD)/tests
	$(CC) $(CFLAGS_ALL) -o $@ $< $(LIB) -lgfortran $(LDLIBS_ALL) -lm
$(BUILD)/obj/tubes_check.o: tests/tubes_check.f90 $(F_OBJ) | $(BUILD)/obj $(BUILD)/mod
	$(FC) $(FFLAGS_ALL) -c $< -o $@
$(BUILD)/obj/tubes_test_models.o: tests/tubes_test_models.f90 $(BUILD)/obj/tubes_check.o $(F_OBJ) | $(BUILD)/obj $(BUILD)/mod
	$(FC) $(FFLAGS_ALL) -c $< -o $@

tests: $(filter-out $(BUILD)/tests/tubes_check,$(T_BIN))

# The MPI flavour is built (into build/mpi, leaving ./tubes serial) and tested with 2 ranks
# whenever an MPI compiler wrapper is installed (make deps installs OpenMPI).
check: all tests
	@$(MAKE) --no-print-directory BUILD=build/debug MODE=debug tests
	@if command -v $(or $(MPIFC),mpifort) >/dev/null 2>&1; then \
	  $(MAKE) --no-print-directory MPI=1 build/mpi/bin/tubes; \
	else echo "check: no mpifort: the MPI flavour is not built or tested"; fi
	@if command -v $(FUZZ_CC) >/dev/null 2>&1; then $(MAKE) --no-print-directory $(FUZZ_BIN); \
	else echo "check: no $(FUZZ_CC): the namelist fuzzer is not built or run"; fi
	@bash tests/run_all.sh

# The fast inner loop (docs/development.md, "make quick"): the optimised build's Fortran and C test
# programs and the Python tests not marked slow (tests/conftest.py SLOW), on 2 pytest workers.
quick: all tests
	@QUICK=1 bash tests/run_all.sh

lint:
	@bash tests/lint.sh

# ---------------------------------------------------------------- sanitizers (docs/development.md)
# Every Fortran and C test program and the executable built with AddressSanitizer and UBSan (and
# -fcheck=all) in build/sanitize; the test programs run, then the executable's pytest suites and
# the paper's input (reduced ensembles) with that build. The Python extension is not sanitized.
sanitize:
	@$(MAKE) --no-print-directory BUILD=build/sanitize MODE=sanitize tests build/sanitize/bin/tubes
	@bash tests/sanitize.sh

# ---------------------------------------------------------------- fuzzing (docs/development.md)
# libFuzzer (clang) on nml_load: the C lexer and validator instrumented, under ASan and UBSan;
# the Fortran reader and the rest of the library linked as built. FUZZ_TIME seconds per target
# (make check: 60 for the namelist, 10 for each Python target).
FUZZ_CC   ?= clang-14
FUZZ_TIME ?= 600
FUZZ_BIN  := $(BUILD)/fuzz/fuzz_namelist
$(FUZZ_BIN): tests/fuzz/fuzz_namelist.c src/io/tubes_input.c include/tubes_input.h include/tubes_config.h $(CONFIG_H) $(REGISTRY_H) $(LIB)
	@mkdir -p $(@D)
	$(FUZZ_CC) -g -O1 -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=undefined -std=c11 \
	  -D_POSIX_C_SOURCE=200809L -Iinclude -I$(BUILD)/include -o $@ tests/fuzz/fuzz_namelist.c src/io/tubes_input.c \
	  $(LIB) $(LDLIBS_ALL) -lgfortran -lgomp
# pip install . into a fresh venv, its outputs against ./tubes' (docs/development.md); .ci/run runs it
pipcheck: all
	@if why=$$(bash tests/pip_check.sh --probe); then bash tests/pip_check.sh; \
	else echo "SKIP pip/install: $$why"; fi

# Python targets: Atheris, tests/fuzz/fuzz_<name>.py with seed corpus tests/fuzz/corpus-<name>
FUZZ_PY   := $(sort $(wildcard tests/fuzz/fuzz_*.py))
fuzz: $(FUZZ_BIN)
	@rc=0; for t in $(FUZZ_BIN) $(FUZZ_PY); do \
	  bash tests/fuzz/run.sh $$t $(FUZZ_TIME) $(if $(FUZZ_MERGE),merge) || rc=1; done; exit $$rc

bench: all
	@bash bench/run.sh

# The paper's results and figures: figures/*.png from build/paper.h5 (docs/paper.md).
paper: all
	./tubes input/paper.nml -o build/paper.h5
	$(VENV)/bin/python -m tubes.figures build/paper.h5 -o figures

docs:
	@$(VENV)/bin/python -c 'import ford' 2>/dev/null || { echo "docs: installing FORD into $(VENV)"; \
	  $(VENV)/bin/python -m pip install --quiet ford; }
	PATH=$(abspath $(VENV))/bin:$$PATH $(VENV)/bin/ford -q docs/ford.md && echo "docs: API documentation in build/doc/index.html"
	@$(VENV)/bin/python -c 'import sphinx' 2>/dev/null || { echo "docs: installing Sphinx into $(VENV)"; \
	  $(VENV)/bin/python -m pip install --quiet sphinx; }
	$(VENV)/bin/python -m sphinx -q -W -b html docs/api build/doc/python && \
	  echo "docs: Python API reference in build/doc/python/index.html"

install: all
	install -d $(PREFIX)/bin $(PREFIX)/lib $(PREFIX)/include
	install -m 755 tubes $(PREFIX)/bin/tubes
	install -m 644 $(LIB) $(PREFIX)/lib/libtubes.a
	install -m 644 include/tubes.h $(PREFIX)/include/tubes.h

clean:
	rm -rf build tubes python/tubes/_core*.so
