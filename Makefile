# Two commands set up a fresh Debian bookworm machine (root, apt reachable):
#   make test   installs the Debian packages, builds the catkin workspace under build/.ws, runs every test
#   make demo   the same build, then the main job on the embedded synthetic scene
# Afterwards `source build/.ws/devel/setup.bash` gives rosrun/roslaunch of this package.
SHELL := /bin/bash
.SHELLFLAGS := -eu -o pipefail -c
PKG := multiview_object_detection
ROOT := $(CURDIR)
# The workspace lies in a dot-folder under build/. Its package folder holds a link to each of this
# repository's entries but build/: a link to the repository itself would put the workspace inside its
# own package, and rosrun's `find -L` over the package reported a file system loop on every call.
WS ?= $(ROOT)/build/.ws
# vision_msgs and jsk_recognition_msgs stand-ins where the real packages are not installed (Debian has
# neither): their own workspace, built first; the package's workspace is built on top of it.
STANDIN_WS ?= $(ROOT)/build/.ws-standin
WS_ENV := set +u; if [ -f $(STANDIN_WS)/devel/setup.sh ]; then . $(STANDIN_WS)/devel/setup.sh; fi; set -u;
JOBS ?= $(shell nproc)
BUILD_TYPE ?= Release
CATKIN_ARGS := -DPYTHON_EXECUTABLE=/usr/bin/python3 -DPython3_EXECUTABLE=/usr/bin/python3 -DCMAKE_BUILD_TYPE=$(BUILD_TYPE) \
	-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCATKIN_ENABLE_TESTING=ON
export CCACHE_DIR ?= $(ROOT)/build/ccache
# Paths under the checkout are hashed relative to it, so checkouts can share one cache (CCACHE_DIR).
export CCACHE_BASEDIR ?= $(ROOT)
export PATH := /usr/bin:$(PATH)

.PHONY: all deps build test test-sanitize demo clean format

all: build

deps:
	@bash scripts/install_deps.sh

# $(call link_package,WORKSPACE): the package folder of WORKSPACE, links made for new entries and removed
# for gone ones (a workspace of the earlier layout, one link to the repository, is converted).
link_package = pkg_dir=$(1)/src/$(PKG); mkdir -p $(1)/src; if [ -L "$$pkg_dir" ]; then rm "$$pkg_dir"; fi; \
	mkdir -p "$$pkg_dir"; find "$$pkg_dir" -maxdepth 1 -xtype l -delete; \
	for entry in $(ROOT)/*; do [ "$$(basename "$$entry")" = build ] || ln -sfn "$$entry" "$$pkg_dir/"; done

.PHONY: workspace sanitize-workspace standin
workspace: standin
	@bash scripts/forget_moved_workspace.sh $(WS)
	@$(call link_package,$(WS))

standin: deps
	@bash scripts/forget_moved_workspace.sh $(STANDIN_WS)
	@bash scripts/build_standin.sh $(STANDIN_WS) $(CATKIN_ARGS) -j$(JOBS)

build: deps workspace
	@$(WS_ENV) cd $(WS) && catkin_make $(CATKIN_ARGS) -j$(JOBS) 2>&1 | grep -v -E '^-- ' | tail -n 40

test: build
	@rm -rf $(WS)/build/test_results
	@$(WS_ENV) cd $(WS) && catkin_make $(CATKIN_ARGS) -j$(JOBS) run_tests 2>&1 | tee $(WS)/run_tests.log \
		| grep -E '^\[ *(RUN|OK|FAILED|PASSED|SKIPPED) |^\[==|FAILURE|ERROR|Skipping|SKIP|error:|Error [0-9]|undefined reference' || true
	@catkin_test_results $(WS)/build/test_results || true
	@/usr/bin/python3 scripts/test_summary.py $(WS)/build/test_results

# make test-sanitize: the same tests built with ASan + UBSan in their own workspace (build/.ws-sanitize), the
# core gtests, conversion and dataset_to_bag gtests and the rostests. Every sanitizer report (those of the nodes
# under rostest too) is collected from $(SAN_LOGS) and the test log and printed; any report, or any failed
# test, makes it exit non-zero. Flags, options, suppressions (upstream code only): test/sanitize/README.md.
SAN_WS ?= $(ROOT)/build/.ws-sanitize
SAN_LOGS := $(SAN_WS)/sanitizer_logs
# Debian's PCL is not instrumented: EIGEN_MALLOC_ALREADY_ALIGNED=1 keeps Eigen's allocator the one PCL was
# built with (Eigen turns it off under ASan), so memory allocated in our code and freed in PCL (or back) matches.
SAN_FLAGS := -fsanitize=address,undefined -fno-omit-frame-pointer -DEIGEN_MALLOC_ALREADY_ALIGNED=1
SAN_CATKIN_ARGS := -DPYTHON_EXECUTABLE=/usr/bin/python3 -DPython3_EXECUTABLE=/usr/bin/python3 \
	-DCMAKE_BUILD_TYPE=RelWithDebInfo '-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g1 -DNDEBUG' \
	'-DCMAKE_CXX_FLAGS=$(SAN_FLAGS)' -DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCATKIN_ENABLE_TESTING=ON \
	-DMVOD_STANDARD_MESSAGES=OFF
SAN_SUPP := $(ROOT)/test/sanitize
# ASan and LSan write their reports to $(SAN_LOGS)/asan.<pid>; gcc's UBSan runtime is a separate library that
# ignores log_path, so its reports go to stderr: the test log, and the ROS logs (ROS_LOG_DIR) of the nodes.
# node_hostile_headers' randomised headers run 60 s here (20 s in make test): memory errors are caught here.
SAN_ENV := ASAN_OPTIONS=alloc_dealloc_mismatch=0:detect_leaks=1:log_path=$(SAN_LOGS)/asan \
	UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=0:suppressions=$(SAN_SUPP)/ubsan.supp \
	LSAN_OPTIONS=suppressions=$(SAN_SUPP)/lsan.supp:print_suppressions=0 ROS_LOG_DIR=$(SAN_LOGS)/ros \
	MVOD_FUZZ_SECONDS=60

sanitize-workspace: standin
	@bash scripts/forget_moved_workspace.sh $(SAN_WS)
	@$(call link_package,$(SAN_WS))

# Built with MVOD_STANDARD_MESSAGES=OFF: the node without vision_msgs and jsk_recognition_msgs is built and
# tested here (make test builds it with their stand-ins).
test-sanitize: deps sanitize-workspace
	@$(WS_ENV) cd $(SAN_WS) && catkin_make $(SAN_CATKIN_ARGS) -j$(JOBS) 2>&1 | grep -v -E '^-- ' | tail -n 40
	@rm -rf $(SAN_WS)/build/test_results $(SAN_LOGS) && mkdir -p $(SAN_LOGS)
	@$(WS_ENV) cd $(SAN_WS) && $(SAN_ENV) catkin_make $(SAN_CATKIN_ARGS) -j$(JOBS) run_tests 2>&1 | tee $(SAN_WS)/run_tests.log \
		| grep -E '^\[ *(RUN|OK|FAILED|PASSED|SKIPPED) |^\[==|FAILURE|ERROR|Skipping|SKIP|error:|Error [0-9]|undefined reference' || true
	@catkin_test_results $(SAN_WS)/build/test_results || true
	@tests=0; /usr/bin/python3 scripts/test_summary.py $(SAN_WS)/build/test_results || tests=$$?; \
		reports=0; /usr/bin/python3 test/sanitize/check_reports.py $(SAN_LOGS) $(SAN_WS)/run_tests.log || reports=$$?; \
		[[ $$tests -eq 0 && $$reports -eq 0 ]]

# make demo DATASET=DIR [FIRST=N LAST=M] [TRAJECTORY=FILE [KEYFRAMES=FILE]]: a 7-Scenes-layout folder or SceneNN
# sequence instead, YOLOv5n-seg (else FastestDet) in the node; a SLAM's TUM trajectory instead of its poses.
DATASET ?=
demo: build
	@bash scripts/demo.sh $(WS) $(DATASET)

# make fuzz [FUZZ_SECONDS=N]: the libFuzzer harnesses of test/fuzz/ (map JSON loader with its save/reload
# round trip, detection JSON reader, depth/mask image decoding), built with clang (ASan + UBSan) outside
# catkin into build/fuzz and run N seconds each (default 60) on copies of their seed corpora. Any crash fails.
FUZZ_SECONDS ?= 60
.PHONY: fuzz
fuzz:
	@bash scripts/install_deps.sh deps/fuzz-packages.txt
	@bash test/fuzz/run_fuzzers.sh $(ROOT)/build/fuzz $(FUZZ_SECONDS)

format:
	@clang-format -i $$(git ls-files '*.cpp' '*.h')

clean:
	rm -rf $(ROOT)/build
