# geosynth build.  `make` builds bin/geosynth; `make help` lists the goals.
#
# Sources are found by globbing: every src/**/*.c goes into build/libgeosynth.a
# (except src/cli/main.c), every tests/unit/test_*.c becomes one cmocka test
# program, every tests/mpi/*.c one MPI test program, every tests/fuzz/fuzz_*.c
# one libFuzzer target. Adding a module or a test needs no Makefile edit.
#
# Variables: SANITIZE=address,undefined  (separate build tree build-san/)
#            PREFIX=/usr/local (install)  T=name (run one test, e.g. T=rng)
#            NP="1 2 3 4" (rank counts for MPI tests)

CC       := mpicc
CXX      := g++
PREFIX   ?= /usr/local
SANITIZE ?=
NP       ?= 1 2 3 4

HDF5_CFLAGS := $(shell pkg-config --cflags hdf5-openmpi 2>/dev/null)
HDF5_LIBS   := $(shell pkg-config --libs hdf5-openmpi 2>/dev/null)
# Thumbnails (src/io/render.c): Mesa's off-screen GL, MIT licence.
OSMESA_CFLAGS := $(shell pkg-config --cflags osmesa 2>/dev/null)
OSMESA_LIBS   := $(shell pkg-config --libs osmesa 2>/dev/null || echo -lOSMesa)
MPI_CFLAGS  := $(shell mpicc --showme:compile 2>/dev/null)

WARN     := -Wall -Wextra -Wstrict-prototypes -Wshadow -Wno-unused-parameter
# WERROR=1 (CI) turns every warning into an error.
ifeq ($(WERROR),1)
WARN     += -Werror
CXXWERROR := -Werror
endif
CFLAGS   ?= -O2 -g
CFLAGS   += -std=c11 -D_POSIX_C_SOURCE=200809L $(WARN) -Iinclude -Isrc $(HDF5_CFLAGS) $(OSMESA_CFLAGS) -MMD -MP
CXXFLAGS ?= -O2 -g
CXXFLAGS += -std=c++17 -Wall -Wextra -Wno-unused-parameter $(CXXWERROR) -Iinclude -Isrc $(MPI_CFLAGS) -MMD -MP
LDLIBS   := $(HDF5_LIBS) -linih -lxxhash -llapacke -llapack -lblas -lpng -lz -lm
# OpenVDB and OSMesa live in plugins loaded on first use (include/geosynth/plugin.h):
# linked into the program they cost every rank ~65 ms of start-up. The programs
# export their symbols (-rdynamic) so the plugins can call gs_* back.
VDB_LIBS := -lopenvdb -ltbb
LDFLAGS  += -rdynamic

ifeq ($(SANITIZE),)
BUILD := build
BIN   := bin
else
BUILD := build-san
BIN   := build-san/bin
CFLAGS   += -fsanitize=$(SANITIZE) -fno-omit-frame-pointer
CXXFLAGS += -fsanitize=$(SANITIZE) -fno-omit-frame-pointer
LDFLAGS  += -fsanitize=$(SANITIZE)
# Keep dlopen'ed plugins loaded so LeakSanitizer names their modules
# (tests/san/nodlclose.c says why); only in sanitizer builds.
SAN_OBJ  := $(BUILD)/tests/san/nodlclose.o
LDFLAGS  += -Wl,--export-dynamic-symbol=dlclose
endif

LIB_SRC  := $(filter-out src/cli/main.c src/plugins/%,$(sort $(wildcard src/*/*.c)))
CLI_SRC  := src/cli/main.c
LIB_OBJ  := $(LIB_SRC:%.c=$(BUILD)/%.o)
LIB      := $(BUILD)/libgeosynth.a
# Plugins: $(BUILD)/plugins/geosynth-NAME.so, found there by programs built here
# (GS_PLUGIN_BUILD_DIR) and in PREFIX/lib/geosynth once installed.
PLUGIN_DIR := $(BUILD)/plugins
PLUGINS  := $(PLUGIN_DIR)/geosynth-vdb.so $(PLUGIN_DIR)/geosynth-render.so

UNIT_SRC := $(sort $(wildcard tests/unit/test_*.c))
UNIT_BIN := $(UNIT_SRC:tests/unit/%.c=$(BUILD)/tests/unit/%)
MPI_SRC  := $(sort $(wildcard tests/mpi/*.c))
MPI_BIN  := $(MPI_SRC:tests/mpi/%.c=$(BUILD)/tests/mpi/%)
BENCH_SRC := $(sort $(wildcard tests/bench/*.c))
BENCH_BIN := $(BENCH_SRC:tests/bench/%.c=$(BUILD)/tests/bench/%)
TEST_UTIL := $(wildcard tests/util/*.c)
TEST_UTIL_OBJ := $(TEST_UTIL:%.c=$(BUILD)/%.o)

FUZZ_SRC := $(sort $(wildcard tests/fuzz/fuzz_*.c))
FUZZ_BIN := $(FUZZ_SRC:tests/fuzz/%.c=build-fuzz/%)

.PHONY: all deps data test unit mpi e2e fuzz fuzz-build valgrind bench demo install clean help tests-build plugins
.DEFAULT_GOAL := all

all: $(BIN)/geosynth

help:
	@echo "make            build bin/geosynth"
	@echo "make deps       install the Debian packages geosynth needs (idempotent)"
	@echo "make data       fetch the third-party example data that may not be redistributed (scripts/fetch-data.sh)"
	@echo "make test       deps + build + every test (unit, MPI np=$(NP), end-to-end, fuzz corpus)"
	@echo "make test T=x   run only tests whose name contains x"
	@echo "make valgrind   unit tests under valgrind"
	@echo "make fuzz       every libFuzzer target for FUZZ_SECONDS (default 60) each, from its seed corpus"
	@echo "make SANITIZE=address,undefined test   the same under ASan/UBSan (build-san/)"
	@echo "make bench      benchmarks, JSON results in bench-results/"
	@echo "make install PREFIX=/opt/geosynth"
	@echo "make clean"

deps:
	@scripts/install-deps.sh

# Third-party examples that may not be redistributed, into the data root
# (GS_DATA, default data/): downloaded at pinned commits, sha256-checked
# (scripts/data-manifest.tsv). GS_DATA_MIRROR=DIR copies from a local folder.
data:
	@scripts/fetch-data.sh

$(BUILD)/%.o: %.c
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS) -c $< -o $@

$(BUILD)/src/io/plugin.o: CFLAGS += -DGS_PLUGIN_BUILD_DIR='"$(abspath $(PLUGIN_DIR))"'
# The data root's default (include/geosynth/data.h): this tree's data/.
DATA_DEF := -DGS_DATA_BUILD_DIR='"$(abspath data)"'
$(BUILD)/src/core/data.o: CFLAGS += $(DATA_DEF)

# The one C++ file (all OpenVDB includes live here); rebuilt only when it changes.
$(BUILD)/src/plugins/vdb.o: src/plugins/vdb.cpp
	@mkdir -p $(dir $@)
	$(CXX) $(CXXFLAGS) -fPIC -c $< -o $@

$(BUILD)/src/plugins/render_gl.o: src/plugins/render_gl.c
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS) -fPIC -c $< -o $@

$(PLUGIN_DIR)/geosynth-vdb.so: $(BUILD)/src/plugins/vdb.o
	@mkdir -p $(dir $@)
	$(CXX) -shared $(filter -fsanitize=%,$(LDFLAGS)) $< $(VDB_LIBS) -o $@

$(PLUGIN_DIR)/geosynth-render.so: $(BUILD)/src/plugins/render_gl.o
	@mkdir -p $(dir $@)
	$(CC) -shared $(filter -fsanitize=%,$(LDFLAGS)) $< $(OSMESA_LIBS) -o $@

plugins: $(PLUGINS)

$(LIB): $(LIB_OBJ)
	@rm -f $@
	ar rcs $@ $^

$(BIN)/geosynth: $(BUILD)/src/cli/main.o $(LIB) $(SAN_OBJ) | $(PLUGINS)
	@mkdir -p $(dir $@)
	$(CC) $(LDFLAGS) $^ $(LDLIBS) -o $@

$(BUILD)/tests/unit/%: tests/unit/%.c $(LIB) $(TEST_UTIL_OBJ) $(SAN_OBJ)
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS) $(LDFLAGS) $< $(TEST_UTIL_OBJ) $(SAN_OBJ) $(LIB) -lcmocka $(LDLIBS) -o $@

$(BUILD)/tests/mpi/%: tests/mpi/%.c $(LIB) $(TEST_UTIL_OBJ) $(SAN_OBJ)
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS) $(LDFLAGS) $< $(TEST_UTIL_OBJ) $(SAN_OBJ) $(LIB) -lcmocka $(LDLIBS) -o $@

$(BUILD)/tests/bench/%: tests/bench/%.c $(LIB) | $(PLUGINS)
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS) -O3 $(LDFLAGS) $< $(LIB) $(LDLIBS) -lfftw3 -o $@

tests-build: $(BIN)/geosynth $(UNIT_BIN) $(MPI_BIN) $(PLUGINS)

# Fuzz targets: clang + libFuzzer + ASan/UBSan over a separate build of the library.
FUZZ_CFLAGS := -std=c11 -D_POSIX_C_SOURCE=200809L -g -O1 -Iinclude -Isrc $(HDF5_CFLAGS) \
               -fsanitize=fuzzer-no-link,address,undefined -MMD -MP
FUZZ_LIB_OBJ := $(LIB_SRC:%.c=build-fuzz/%.o)
build-fuzz/%.o: %.c
	@mkdir -p $(dir $@)
	OMPI_CC=clang mpicc $(FUZZ_CFLAGS) -c $< -o $@
# The fuzz programs never reach the plugins: they are not built for them.
build-fuzz/src/io/plugin.o: FUZZ_CFLAGS += -DGS_PLUGIN_BUILD_DIR='"$(abspath build-fuzz/plugins)"'
build-fuzz/src/core/data.o: FUZZ_CFLAGS += $(DATA_DEF)
build-fuzz/fuzz_%: tests/fuzz/fuzz_%.c $(FUZZ_LIB_OBJ)
	@mkdir -p $(dir $@)
	OMPI_CC=clang mpicc $(FUZZ_CFLAGS) -fsanitize=fuzzer -rdynamic $< $(FUZZ_LIB_OBJ) $(LDLIBS) -o $@

# `make fuzz` builds every target and fuzzes each for FUZZ_SECONDS (default 60;
# `make fuzz FUZZ_SECONDS=600 T=fuzz_image` for one), starting from its seed
# corpus; crashing inputs are kept as build/test-logs/fuzz_NAME-crash-* (copy
# them into tests/fuzz/corpus/NAME/ as regression inputs once fixed).
# A campaign draws a fresh seed (FUZZ_SEED=0) unless FUZZ_SEED is given; `make test`
# runs the same with 15 s each from seed 1.
FUZZ_SECONDS ?= 60
fuzz-build: $(FUZZ_BIN)
fuzz: fuzz-build
	@BUILD=$(BUILD) BIN=$(BIN) T="$(T)" FUZZ_SECONDS=$(FUZZ_SECONDS) FUZZ_SEED=$${FUZZ_SEED:-0} tests/run.sh fuzz

# Keep the fuzz build's objects (they are intermediates of the fuzz programs).
.SECONDARY: $(FUZZ_LIB_OBJ)

# `make test` is the whole set-up on a fresh Debian 12 machine: it installs what
# is missing, builds, and runs every suite, ending with "N passed, N failed".
# A selection of only unit/, mpi/ and e2e/ tests (T="e2e/field unit/test_mesh")
# does not build the fuzz targets (an ASan+libFuzzer build of the library).
comma := ,
TEST_NEEDS_FUZZ := $(if $(strip $(T)),$(filter-out unit/% mpi/% e2e/%,$(subst $(comma), ,$(T))),all)
test: deps
	@$(MAKE) --no-print-directory tests-build $(if $(TEST_NEEDS_FUZZ),fuzz-build)
	@BUILD=$(BUILD) BIN=$(BIN) NP="$(NP)" T="$(T)" tests/run.sh

valgrind: tests-build
	@BUILD=$(BUILD) BIN=$(BIN) T="$(T)" VALGRIND=1 tests/run.sh unit

bench: deps
	@$(MAKE) --no-print-directory $(BIN)/geosynth $(BENCH_BIN)
	@BUILD=$(BUILD) BIN=$(BIN) tests/bench/run.sh

demo: deps
	@$(MAKE) --no-print-directory $(BIN)/geosynth
	@scripts/demo.sh

install: $(BIN)/geosynth $(PLUGINS)
	install -d $(DESTDIR)$(PREFIX)/bin $(DESTDIR)$(PREFIX)/lib/geosynth $(DESTDIR)$(PREFIX)/share/geosynth/configs \
	           $(DESTDIR)$(PREFIX)/share/geosynth/data
	install -m 755 $(BIN)/geosynth $(DESTDIR)$(PREFIX)/bin/geosynth
	install -m 755 $(PLUGINS) $(DESTDIR)$(PREFIX)/lib/geosynth/
	cp -r configs/. $(DESTDIR)$(PREFIX)/share/geosynth/configs/
	cp -r data/. $(DESTDIR)$(PREFIX)/share/geosynth/data/

clean:
	rm -rf build build-san build-fuzz bin bench-results

-include $(shell find build build-san build-fuzz -name '*.d' 2>/dev/null)
