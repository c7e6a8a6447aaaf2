# prt: all-frequency precomputed radiance transfer.
#   make            build build/prt (installs missing Debian packages first)
#   make test       build and run the test suite (SAN=1 for ASan + UBSan; T=haar: only matching cases)
#   make demo       build and run `prt demo` (writes demo.png)
#   make bench      benchmarks on ../shared/data (not tests; tools/bench_lights.sh: issue 11's local lights)
#   make study      accuracy-versus-time study (docs/study/)
#   make study-glossy  vMF lobes against the SVD path on the glossy scenes (docs/study/glossy/)
SHELL := /bin/bash
CC  ?= cc
CXX ?= c++
SAN ?= 0
OPT ?= -O2

ifeq ($(SAN),1)
BUILD := build/san
SANFLAGS := -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined
else
BUILD := build
SANFLAGS :=
endif

# Debian packages the project needs; `make deps` installs the missing ones.
DEB_PKGS := build-essential pkg-config libembree-dev libopenimageio-dev libopenexr-dev \
            liblapacke-dev libopenblas-dev libosmesa6-dev libglfw3-dev libgl-dev libegl-dev \
            zlib1g-dev libcjson-dev xvfb xauth

# Library folders by pipeline stage (README "Architecture"); headers are included by name.
SRC_DIRS := src/core src/scene src/light src/image src/transfer src/precompute src/file src/runtime src/reference
INCS    := $(addprefix -I,$(SRC_DIRS)) -Isrc/cli -Ibrdf -Igpu
CFLAGS  += -std=c11 $(OPT) -g -Wall -Wextra -Wno-unused-parameter -D_GNU_SOURCE -march=x86-64-v2 \
           -pthread $(INCS) -MMD -MP $(SANFLAGS)
CXXFLAGS+= -std=c++17 $(OPT) -g -Wall -Wextra -pthread $(INCS) -MMD -MP $(SANFLAGS)
LDLIBS  := -lembree3 -lOpenImageIO -lOpenImageIO_Util -llapacke -lopenblas -lOSMesa -lglfw -lGL -lEGL \
           -lcjson -lz -lm -lpthread -lstdc++
LDFLAGS += -pthread $(SANFLAGS)

# Library: every source of the stage folders, brdf/ and gpu/; the command-line front end is src/cli/.
LIB_C   := $(wildcard $(addsuffix /*.c,$(SRC_DIRS)) brdf/*.c gpu/*.c)
LIB_CXX := $(wildcard $(addsuffix /*.cpp,$(SRC_DIRS)))
LIB_OBJ := $(LIB_C:%.c=$(BUILD)/obj/%.o) $(LIB_CXX:%.cpp=$(BUILD)/obj/%.o)
CLI_OBJ := $(patsubst %.c,$(BUILD)/obj/%.o,$(wildcard src/cli/*.c))
TESTS   := $(patsubst tests/%.c,$(BUILD)/tests/%,$(wildcard tests/test_*.c))
TEST_SUPPORT := $(patsubst %.c,$(BUILD)/obj/%.o,$(filter-out tests/test_%.c,$(wildcard tests/*.c)))

.PHONY: all deps test demo bench study study-glossy clean
# Keep the test objects (they are intermediate files of the test binaries).
.SECONDARY:
all: $(BUILD)/.deps $(BUILD)/prt

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

$(BUILD)/obj/%.o: %.c | $(BUILD)/.deps
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS) -c $< -o $@
$(BUILD)/obj/%.o: %.cpp | $(BUILD)/.deps
	@mkdir -p $(dir $@)
	$(CXX) $(CXXFLAGS) -c $< -o $@

$(BUILD)/libprt.a: $(LIB_OBJ)
	@rm -f $@
	ar rcs $@ $^
$(BUILD)/prt: $(CLI_OBJ) $(BUILD)/libprt.a
	$(CC) $(LDFLAGS) $(CLI_OBJ) $(BUILD)/libprt.a $(LDLIBS) -o $@
$(BUILD)/tests/%: $(BUILD)/obj/tests/%.o $(TEST_SUPPORT) $(BUILD)/libprt.a
	@mkdir -p $(dir $@)
	$(CC) $(LDFLAGS) $< $(TEST_SUPPORT) $(BUILD)/libprt.a $(LDLIBS) -o $@

# T=FILTER runs only the cases whose "domain/case" name contains FILTER (tests/harness.h).
test: all $(TESTS)
	@T="$(T)" PRT_BIN=$(BUILD)/prt tools/run_tests.sh $(TESTS)

demo: all
	$(BUILD)/prt demo -o demo.png

bench: all
	@tools/bench.sh $(BUILD)/prt
	@echo
	@tools/bench_glossy.sh $(BUILD)/prt
	@echo
	@tools/bench_lights.sh $(BUILD)/prt

study: all
	@tools/study.sh $(BUILD)/prt

# issue 9: vMF against SVD K = 1..16 (about 35 min on 2 cores; STUDY_QUICK=1 for a one-minute check)
study-glossy: all
	@tools/study_glossy.sh $(BUILD)/prt

clean:
	rm -rf build

-include $(shell find build -name '*.d' 2>/dev/null)
