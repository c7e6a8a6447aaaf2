# prt: all-frequency precomputed radiance transfer.
#   make            build build/prt (installs missing Debian packages first)
#   make test       build and run the test suite (SAN=1 for ASan + UBSan; T=haar: only matching cases)
#   make test-portable  the suite three times on other CPUs' code paths (OpenBLAS kernels, Embree
#                   at SSE4.2, libm without FMA; tools/test_portable.sh), about 3x `make test`
#   make demo       build and run `prt demo` (writes demo.png)
#   make bench      benchmarks on ../shared/data (not tests; tools/bench_lights.sh: the local lights)
#   make bench-scale  the direct pass at 100 K, 300 K and 1 M vertices, mpirun -np 2
#   make study      accuracy-versus-time study (docs/study/)
#   make study-glossy  vMF lobes against the SVD path on the glossy scenes (docs/study/glossy/)
#   make accuracy   PRT against the path tracer: scenes x probes x yaws x effects (docs/accuracy/;
#                   ACCURACY_QUICK=1 for a few minutes; tools/accuracy.sh says the knobs)
#   make fuzz       libFuzzer harnesses of every loader and parser (tests/fuzz/), FUZZ_SECONDS each and/or to
#                   FUZZ_RUNS executions each (default 60 s), FUZZ_JOBS processes of each at once (default 1)
#   make NO_GL=1 [test]  without OSMesa, GLFW or EGL, into build/nogl: the library, the CPU runtime and the
#                   CLI's non-GL commands (runtime.h: no gl backend, the cpu one draws no images)
#   make install    libprt.so, libprt.a, the public headers, prt.pc and prt under PREFIX (default /usr/local;
#                   DESTDIR honoured); make uninstall removes them (docs/api.md)
SHELL := /bin/bash
CC  ?= cc
CXX ?= c++
SAN ?= 0
OPT ?= -O2

ifeq ($(FUZZ),1)
# `make fuzz` builds the library again with clang, instrumented for libFuzzer (tests/fuzz/).
CC  := clang
CXX := clang++
BUILD := build/fuzz
SANFLAGS := -fsanitize=fuzzer-no-link,address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined
else ifeq ($(SAN),1)
BUILD := build/san
SANFLAGS := -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined
else
BUILD := build
SANFLAGS :=
endif

# GL: the gpu/ folder, its packages and libraries, and the viewer. NO_GL=1 leaves all of it out (PRT_NO_GL:
# runtime.c's table has no gl backend), and the test binaries that need GL; cases that need it inside
# the others are skipped with their reason (tests/harness.h: CHECK_CASE_GL). The fuzz smoke run is
# not part of it (its harnesses are the clang build of build/fuzz).
GL_PKGS := libosmesa6-dev libglfw3-dev libgl-dev libegl-dev xvfb xauth
GL_LIBS := -lOSMesa -lglfw -lGL -lEGL
GL_PC   := osmesa glfw3 egl gl
GL_DIRS := gpu
FUZZ_SMOKE := tools/fuzz.sh
ifeq ($(NO_GL),1)
BUILD := $(BUILD)/nogl
GL_PKGS :=
GL_LIBS :=
GL_PC   :=
GL_DIRS :=
GL_ONLY := src/cli/cli_view.c tests/test_glrt.c tests/test_render.c tests/test_view.c tests/test_truth.c
FUZZ_SMOKE :=
CFLAGS += -DPRT_NO_GL
CXXFLAGS += -DPRT_NO_GL
endif

# Debian packages the project needs; `make deps` installs the missing ones.
DEB_PKGS := build-essential pkg-config libembree-dev libopenimageio-dev libopenexr-dev \
            liblapacke-dev libopenblas-dev $(GL_PKGS) \
            zlib1g-dev libcjson-dev libopenmpi-dev openmpi-bin libassimp-dev
# Debian packages only the tests use (tests/test_asset.c loads assimp's glTF sample models when present);
# `make test` installs the missing ones.
TEST_DEB_PKGS := assimp-testmodels

# Library folders by pipeline stage (README "Architecture"); headers are included by name. Every folder
# under src/transfer/ is one (a representation's, or what several share: transfer.h).
TRANSFER_DIRS := $(patsubst %/,%,$(sort $(wildcard src/transfer/*/)))
SRC_DIRS := src/core src/scene src/locallight src/image src/transfer $(TRANSFER_DIRS) src/precompute src/file src/runtime src/reference
INCS    := $(addprefix -I,$(SRC_DIRS)) -Isrc/cli -Ibrdf $(addprefix -I,$(GL_DIRS))
CFLAGS  += -std=c11 $(OPT) -g -Wall -Wextra -Wno-unused-parameter -D_GNU_SOURCE -march=x86-64-v2 \
           -pthread $(INCS) -MMD -MP $(SANFLAGS)
CXXFLAGS+= -std=c++17 $(OPT) -g -Wall -Wextra -pthread $(INCS) -MMD -MP $(SANFLAGS)
# OpenMPI (src/precompute/shard.c): asked of pkg-config when used, after `deps` has installed it.
MPI_CFLAGS = $(shell pkg-config --cflags ompi-c)
MPI_LIBS   = $(shell pkg-config --libs ompi-c)
# assimp (src/scene/asset.c: glTF, PLY, OBJ + MTL): asked of pkg-config, after `deps` has installed it.
ASSIMP_LIBS = $(shell pkg-config --libs assimp)
LDLIBS   = -lembree3 -lOpenImageIO -lOpenImageIO_Util -llapacke -lopenblas $(GL_LIBS) \
           -lcjson -lz -lm -lpthread -lstdc++ $(MPI_LIBS) $(ASSIMP_LIBS)
LDFLAGS += -pthread $(SANFLAGS)

# Installation. The version is common.h's; SO_ABI, the SONAME's number, changes with every change to
# the installed headers that breaks a program built against them (docs/api.md, "What is stable").
PREFIX     ?= /usr/local
BINDIR     ?= $(PREFIX)/bin
LIBDIR     ?= $(PREFIX)/lib
INCLUDEDIR ?= $(PREFIX)/include
VERSION := $(shell sed -n 's/^\#define PRT_VERSION_STRING "\(.*\)"/\1/p' $(wildcard src/*/common.h))
SO_ABI  := 1
SONAME  := libprt.so.$(SO_ABI)
SO_FILE := libprt.so.$(VERSION)
# prt.pc: the libraries libprt uses, by their pkg-config names (Requires.private), and those without one
PC_REQUIRES := OpenImageIO lapacke openblas $(GL_PC) libcjson zlib ompi-c assimp
PC_LIBS     := -lembree3 -lstdc++ -lm -lpthread
# The public headers: src/prt.h and every project header it includes, installed flat into
# INCLUDEDIR/prt (the project includes headers by name, so no two share a name).
PUBLIC_H = $(sort $(filter %.h,$(shell $(CC) -MM -MT x $(INCS) src/prt.h)))

# Library: every source of the stage folders, brdf/ and gpu/ (not with NO_GL=1); the command-line front end is src/cli/.
LIB_C   := $(wildcard $(addsuffix /*.c,$(SRC_DIRS) $(GL_DIRS)) brdf/*.c)
LIB_CXX := $(wildcard $(addsuffix /*.cpp,$(SRC_DIRS)))
LIB_OBJ := $(LIB_C:%.c=$(BUILD)/obj/%.o) $(LIB_CXX:%.cpp=$(BUILD)/obj/%.o)
CLI_OBJ := $(patsubst %.c,$(BUILD)/obj/%.o,$(filter-out $(GL_ONLY),$(wildcard src/cli/*.c)))
TESTS   := $(patsubst tests/%.c,$(BUILD)/tests/%,$(filter-out $(GL_ONLY),$(wildcard tests/test_*.c)))
# A test with its own library code: tests/NAME/test_NAME.c and the sources beside it, linked before libprt.a
# so that they may stand in for a library object (tests/dense/ links its own transfer table).
TEST_DIRS := $(patsubst tests/%/,%,$(dir $(wildcard tests/*/test_*.c)))
TESTS   += $(TEST_DIRS:%=$(BUILD)/tests/test_%)
TEST_SUPPORT := $(patsubst %.c,$(BUILD)/obj/%.o,$(filter-out tests/test_%.c,$(wildcard tests/*.c)))

.PHONY: all deps incs libs test test-portable demo bench bench-scale study study-glossy accuracy fuzz fuzz-build install uninstall clean
# Keep the test objects (they are intermediate files of the test binaries).
.SECONDARY:
all: $(BUILD)/.deps $(BUILD)/prt $(BUILD)/$(SO_FILE)

# Install missing Debian packages once (root: apt-get; otherwise sudo if available).
$(BUILD)/.deps:
	@mkdir -p $(BUILD)
	@missing=""; for p in $(DEB_PKGS); do dpkg -s $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
	if [ -n "$$missing" ]; then \
	  echo "installing Debian packages:$$missing"; \
	  if [ "$$(id -u)" = 0 ]; then SUDO=""; else SUDO="sudo"; fi; \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq $$missing; \
	fi
	@touch $@
deps: $(BUILD)/.deps
# The tests' own packages, installed once the same way.
$(BUILD)/.testdeps: | $(BUILD)/.deps
	@missing=""; for p in $(TEST_DEB_PKGS); do dpkg -s $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
	if [ -n "$$missing" ]; then \
	  echo "installing Debian packages for the tests:$$missing"; \
	  if [ "$$(id -u)" = 0 ]; then SUDO=""; else SUDO="sudo"; fi; \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq $$missing; \
	fi
	@touch $@

$(BUILD)/obj/%.o: %.c | $(BUILD)/.deps
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS) -c $< -o $@
$(BUILD)/obj/%.o: %.cpp | $(BUILD)/.deps
	@mkdir -p $(dir $@)
	$(CXX) $(CXXFLAGS) -c $< -o $@

$(BUILD)/obj/src/precompute/shard.o: CFLAGS += $(MPI_CFLAGS)
# Every library object is position-independent, so one build serves libprt.a and libprt.so; without
# semantic interposition the compiler may inline the library's functions into each other as it does
# under -fPIE, so the code is -fPIE's but for the addresses of globals (docs/api.md).
$(LIB_OBJ): CFLAGS += -fPIC -fno-semantic-interposition
$(LIB_OBJ): CXXFLAGS += -fPIC -fno-semantic-interposition
# A tree without the stamp $(BUILD)/.pic (left by the archive's rule) may hold objects compiled
# without -fPIC: they are compiled again, once.
ifeq ($(wildcard $(BUILD)/.pic),)
$(LIB_OBJ): pic-rebuild
endif
.PHONY: pic-rebuild

$(BUILD)/libprt.a: $(LIB_OBJ)
	@rm -f $@
	ar rcs $@ $^
	@touch $(BUILD)/.pic
$(BUILD)/$(SO_FILE): $(LIB_OBJ)
	$(CC) -shared -Wl,-soname,$(SONAME) -Wl,-z,defs $(LDFLAGS) $^ $(LDLIBS) -o $@
$(BUILD)/prt: $(CLI_OBJ) $(BUILD)/libprt.a
	$(CC) $(LDFLAGS) $(CLI_OBJ) $(BUILD)/libprt.a $(LDLIBS) -o $@
$(BUILD)/tests/%: $(BUILD)/obj/tests/%.o $(TEST_SUPPORT) $(BUILD)/libprt.a
	@mkdir -p $(dir $@)
	$(CC) $(LDFLAGS) $< $(TEST_SUPPORT) $(BUILD)/libprt.a $(LDLIBS) -o $@
define TEST_DIR_RULE
$(patsubst %.c,$(BUILD)/obj/%.o,$(wildcard tests/$(1)/*.c)): CFLAGS += -Itests
$(BUILD)/tests/test_$(1): $(patsubst %.c,$(BUILD)/obj/%.o,$(wildcard tests/$(1)/*.c)) $(TEST_SUPPORT) $(BUILD)/libprt.a
	@mkdir -p $$(dir $$@)
	$$(CC) $$(LDFLAGS) $$(filter %.o,$$^) $(BUILD)/libprt.a $$(LDLIBS) -o $$@
endef
$(foreach d,$(TEST_DIRS),$(eval $(call TEST_DIR_RULE,$(d))))

install: all
	@dups=$$(for h in $(PUBLIC_H); do basename $$h; done | sort | uniq -d); \
	  if [ -n "$$dups" ]; then echo "install: two public headers named $$dups"; exit 1; fi
	install -d $(DESTDIR)$(BINDIR) $(DESTDIR)$(LIBDIR)/pkgconfig $(DESTDIR)$(INCLUDEDIR)/prt
	install -m 755 $(BUILD)/prt $(DESTDIR)$(BINDIR)/prt
	install -m 755 $(BUILD)/$(SO_FILE) $(DESTDIR)$(LIBDIR)/$(SO_FILE)
	ln -sf $(SO_FILE) $(DESTDIR)$(LIBDIR)/$(SONAME)
	ln -sf $(SONAME) $(DESTDIR)$(LIBDIR)/libprt.so
	install -m 644 $(BUILD)/libprt.a $(DESTDIR)$(LIBDIR)/libprt.a
	install -m 644 $(PUBLIC_H) $(DESTDIR)$(INCLUDEDIR)/prt/
	sed -e 's|@PREFIX@|$(PREFIX)|; s|@LIBDIR@|$(LIBDIR)|; s|@INCLUDEDIR@|$(INCLUDEDIR)|; s|@VERSION@|$(VERSION)|' \
	    -e 's|@REQUIRES@|$(PC_REQUIRES)|; s|@LIBS@|$(PC_LIBS)|' prt.pc.in > $(DESTDIR)$(LIBDIR)/pkgconfig/prt.pc
uninstall:
	rm -f $(DESTDIR)$(BINDIR)/prt $(DESTDIR)$(LIBDIR)/$(SO_FILE) $(DESTDIR)$(LIBDIR)/$(SONAME) \
	      $(DESTDIR)$(LIBDIR)/libprt.so $(DESTDIR)$(LIBDIR)/libprt.a $(DESTDIR)$(LIBDIR)/pkgconfig/prt.pc
	rm -rf $(DESTDIR)$(INCLUDEDIR)/prt

# T=FILTER runs only the cases whose "domain/case" name contains FILTER (tests/harness.h).
# The fuzz harnesses' smoke run (tools/fuzz.sh without arguments: the seeds and a few seconds each) is the
# suite's last binary; it prints a skip reason when clang's libFuzzer is missing.
test: all $(TESTS) $(BUILD)/.testdeps
	@T="$(T)" PRT_BIN=$(BUILD)/prt tools/run_tests.sh $(TESTS) $(FUZZ_SMOKE)

# The same suite under three sets of CPU-dependent code paths (tools/test_portable.sh says which).
test-portable: all $(TESTS) $(BUILD)/.testdeps
	@T="$(T)" tools/test_portable.sh $(BUILD)/prt $(TESTS) tools/fuzz.sh

# libFuzzer harnesses (tests/fuzz/fuzz_NAME.c, seeds in tests/fuzz/corpus/NAME/): built with clang,
# ASan and UBSan into build/fuzz/, then each run for FUZZ_SECONDS and/or to FUZZ_RUNS executions
# (all FUZZ_JOBS processes together; tools/fuzz.sh). Neither given: 60 s each.
FUZZ_SECONDS ?=
FUZZ_RUNS ?=
FUZZ_PKGS := clang libclang-rt-dev
FUZZERS := $(patsubst tests/fuzz/%.c,build/fuzz/%,$(wildcard tests/fuzz/fuzz_*.c))
FUZZ_CLI_OBJ := $(BUILD)/obj/src/cli/cli_args.o
fuzz: all
	@tools/fuzz.sh $(if $(FUZZ_RUNS),--runs $(FUZZ_RUNS)) $(if $(FUZZ_SECONDS),--seconds $(FUZZ_SECONDS),$(if $(FUZZ_RUNS),,--seconds 60))
# Installs clang and its runtime libraries (libFuzzer) when missing, then builds the harnesses.
fuzz-build: $(BUILD)/.deps
	@if ! command -v clang >/dev/null || ! ls /usr/lib/llvm-*/lib/clang/*/lib/linux/libclang_rt.fuzzer-x86_64.a >/dev/null 2>&1; then \
	  echo "installing clang and libFuzzer"; \
	  if [ "$$(id -u)" = 0 ]; then SUDO=""; else SUDO="sudo"; fi; \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq $(FUZZ_PKGS); \
	fi
	@$(MAKE) --no-print-directory FUZZ=1 $(FUZZERS)
ifeq ($(FUZZ),1)
# Linked by clang++ (libFuzzer and UBSan's C++ runtimes); clang 14's half-float conversions
# (transfer_vmf.c) are in compiler-rt's builtins, not libgcc. tests/fuzz/absent.o, linked before
# the library, stands in for the libraries no harness calls (OpenImageIO, OSMesa, EGL, GLFW,
# Embree, LAPACKE, OpenBLAS, OpenMPI): the binaries need only FUZZ_LDLIBS (tools/fuzz_pack.sh; assimp, not
# instrumented, for the asset harnesses' readers).
FUZZ_LDLIBS := -lcjson -lz -lm -lpthread $(ASSIMP_LIBS)
build/fuzz/fuzz_%: $(BUILD)/obj/tests/fuzz/fuzz_%.o $(BUILD)/obj/tests/fuzz/absent.o $(BUILD)/libprt.a $(FUZZ_CLI_OBJ)
	@mkdir -p $(dir $@)
	$(CXX) -fsanitize=fuzzer,address,undefined $< $(BUILD)/obj/tests/fuzz/absent.o $(FUZZ_CLI_OBJ) $(BUILD)/libprt.a \
	    $(FUZZ_LDLIBS) $$($(CC) -print-libgcc-file-name --rtlib=compiler-rt) -o $@
$(BUILD)/obj/tests/fuzz/%.o: CFLAGS += -Itests/fuzz
# A bright pixel's refined cube texels take at most 4 x 4 sub-samples instead of 64 x 64
# (PROBE_MAX_SS, probe.c): the same code, at a cost that lets fuzz_probe resample every input.
$(BUILD)/obj/src/image/probe.o: CFLAGS += -DPROBE_MAX_SS=4
endif

demo: all
	$(BUILD)/prt demo -o demo.png

bench: all
	@tools/bench.sh $(BUILD)/prt
	@echo
	@tools/bench_glossy.sh $(BUILD)/prt
	@echo
	@tools/bench_lights.sh $(BUILD)/prt

# the direct pass at 100 K, 300 K and 1 M vertices, and mpirun -np 2 against 2 threads
# (SCALE_SIZES="100k 300k" for fewer; tools/bench_scale.sh says the knobs)
bench-scale: all
	@tools/bench_scale.sh $(BUILD)/prt

study: all
	@tools/study.sh $(BUILD)/prt

# vMF against SVD K = 1..16 (about 35 min on 2 cores; STUDY_QUICK=1 for a one-minute check)
study-glossy: all
	@tools/study_glossy.sh $(BUILD)/prt

# the image error of every shared-asset scene under the eight probes at two yaws, direct only and with
# bounces, beside the reference's own noise and over the floor's shadow (hours on 2 cores at the defaults)
accuracy: all
	@tools/accuracy.sh $(BUILD)/prt

clean:
	rm -rf build

-include $(shell find build -name '*.d' 2>/dev/null)

# The include flags of the library's folders, for the tools that build against it (tools/*.sh).
incs:
	@echo $(INCS)

# The libraries they link after build/libprt.a.
libs:
	@echo $(LDLIBS)
