# Two commands set up a fresh Debian bookworm machine (root, apt reachable):
#   make test   installs the Debian packages, builds the catkin workspace under build/.ws, runs every test
#   make demo   the same build, then the main job on the embedded synthetic scene
# Afterwards `source build/.ws/devel/setup.bash` gives rosrun/roslaunch of this package.
SHELL := /bin/bash
.SHELLFLAGS := -eu -o pipefail -c
PKG := multiview_object_detection
ROOT := $(CURDIR)
# The workspace lies in a dot-folder: its src/ links back to this repository, and roslib's package
# crawl (roslaunch's $$(find)) follows links but skips dot-folders, so it does not loop through it.
WS ?= $(ROOT)/build/.ws
JOBS ?= $(shell nproc)
BUILD_TYPE ?= Release
CATKIN_ARGS := -DPYTHON_EXECUTABLE=/usr/bin/python3 -DPython3_EXECUTABLE=/usr/bin/python3 -DCMAKE_BUILD_TYPE=$(BUILD_TYPE) \
	-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCATKIN_ENABLE_TESTING=ON
export CCACHE_DIR ?= $(ROOT)/build/ccache
# Paths under the checkout are hashed relative to it, so checkouts can share one cache (CCACHE_DIR).
export CCACHE_BASEDIR ?= $(ROOT)
export PATH := /usr/bin:$(PATH)

.PHONY: all deps build test demo clean format

all: build

deps:
	@bash scripts/install_deps.sh

$(WS)/src/$(PKG):
	@mkdir -p $(WS)/src
	@ln -sfn $(ROOT) $(WS)/src/$(PKG)

build: deps $(WS)/src/$(PKG)
	@cd $(WS) && catkin_make $(CATKIN_ARGS) -j$(JOBS) 2>&1 | grep -v -E '^-- ' | tail -n 40

test: build
	@rm -rf $(WS)/build/test_results
	@cd $(WS) && catkin_make $(CATKIN_ARGS) -j$(JOBS) run_tests 2>&1 | tee $(WS)/run_tests.log \
		| grep -E '^\[ *(RUN|OK|FAILED|PASSED|SKIPPED) |^\[==|FAILURE|ERROR|Skipping|SKIP|error:|Error [0-9]|undefined reference' || true
	@catkin_test_results $(WS)/build/test_results || true
	@/usr/bin/python3 scripts/test_summary.py $(WS)/build/test_results

# make demo DATASET=DIR [FIRST=N LAST=M]: a 7-Scenes-layout folder or SceneNN sequence instead, FastestDet in the node.
DATASET ?=
demo: build
	@bash scripts/demo.sh $(WS) $(DATASET)

format:
	@clang-format -i $$(git ls-files '*.cpp' '*.h')

clean:
	rm -rf $(ROOT)/build
