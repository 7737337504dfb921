# Two commands do everything on a fresh Debian 12: `make demo` and `make test`.
SHELL := /bin/bash
.SHELLFLAGS := -eo pipefail -c
WS := $(CURDIR)
VENV := $(WS)/.venv
STAMPS := $(WS)/.stamps
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)
JOBS ?= 2

# Debian's own ROS 1 (catkin, roscore, roslaunch, rostest, rosbag), OpenCV, Eigen, offscreen Mesa; aiohttp for the
# web operator station, headless Chromium + chromium-driver + Selenium for its browser tests; rosbag_storage,
# topic_tools and jemalloc for the flight recorder (flight_recorder, interface/launch/record.launch); libapriltag
# for the AprilTag pad's detector (uav_vision).
APT_PACKAGES := build-essential cmake python3-venv python3-dev python3-pip python3-yaml python3-numpy python3-pytest \
  catkin ros-base-dev python3-rospy python3-roslaunch python3-rostest python3-rosbag python3-rosnode \
  python3-rostopic python3-rosparam python3-rosservice python3-rosgraph rosbash ros-message-generation \
  ros-message-runtime libstd-msgs-dev python3-std-msgs libsensor-msgs-dev python3-sensor-msgs \
  libnav-msgs-dev python3-nav-msgs libgeometry-msgs-dev python3-geometry-msgs python3-rosgraph-msgs \
  libcv-bridge-dev python3-cv-bridge libimage-transport-dev libtf2-ros-dev python3-tf2-ros \
  libtf2-geometry-msgs-dev python3-tf2-geometry-msgs libopencv-dev python3-opencv libeigen3-dev \
  libgtest-dev googletest libosmesa6 libgl1 libglfw3 rviz \
  python3-std-srvs libstd-srvs-dev libyaml-cpp-dev \
  python3-aiohttp chromium chromium-driver python3-selenium libjemalloc2 librosbag-storage-dev libtopic-tools-dev \
  libapriltag-dev

.PHONY: all deps build test check demo bench clean

all: build

$(STAMPS)/apt: Makefile
	@mkdir -p $(STAMPS)
	@missing=""; for p in $(APT_PACKAGES); do \
	  dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "install ok installed" || missing="$$missing $$p"; done; \
	if [ -n "$$missing" ]; then \
	  echo "== installing Debian packages:$$missing"; \
	  $(SUDO) apt-get update -q; \
	  DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -q --no-install-recommends $$missing; \
	fi
	@touch $@

$(STAMPS)/venv: requirements.txt $(STAMPS)/apt
	@echo "== Python venv (system site-packages for ROS) with pinned packages"
	/usr/bin/python3 -m venv --system-site-packages $(VENV)
	$(VENV)/bin/pip install -q --disable-pip-version-check -r requirements.txt
	@touch $@

# So that `.venv/bin/python -m landing_eval.analyze BAG --out DIR` works in a shell where nothing is sourced: the
# entry point (landing_eval) and the ROS-free analysis it calls (flight_analysis).
$(STAMPS)/pth: Makefile $(STAMPS)/venv
	site="$$($(VENV)/bin/python -c 'import site; print(site.getsitepackages()[0])')"; \
	rm -f "$$site/landing_interface.pth"; \
	printf '%s\n' "$(WS)/src/landing_eval/src" "$(WS)/src/flight_analysis/src" > "$$site/landing_eval.pth"
	@touch $@

deps: $(STAMPS)/venv $(STAMPS)/pth

# The message-only stand-ins for the drivers' interfaces (src/ardrone_autonomy, src/mavros_msgs) are built only
# where the real package is not installed: a real one in /opt/ros, /usr/share or a sourced underlay
# (CMAKE_PREFIX_PATH) wins, and the stand-in gets a CATKIN_IGNORE.
STANDINS := ardrone_autonomy mavros_msgs
build: deps
	@for pkg in $(STANDINS); do \
	  real=""; for prefix in /opt/ros/* /usr $$(echo "$${CMAKE_PREFIX_PATH:-}" | tr ':' ' '); do \
	    case "$$prefix" in "$(WS)"*) continue;; esac; \
	    [ -f "$$prefix/share/$$pkg/package.xml" ] && real="$$prefix/share/$$pkg"; done; \
	  if [ -n "$$real" ]; then echo "== $$pkg: the real package in $$real is used (src/$$pkg ignored)"; \
	    touch src/$$pkg/CATKIN_IGNORE; else rm -f src/$$pkg/CATKIN_IGNORE; fi; done
	@echo "== catkin_make"
	export PATH="$(VENV)/bin:$$PATH"; \
	catkin_make -C $(WS) -j$(JOBS) -DPYTHON_EXECUTABLE=$(VENV)/bin/python -DCMAKE_BUILD_TYPE=Release \
	  -DCATKIN_ENABLE_TESTING=ON -DSETUPTOOLS_DEB_LAYOUT=OFF > $(WS)/.stamps/build.log 2>&1 \
	  || { tail -n 60 $(WS)/.stamps/build.log; echo "catkin_make failed: full log in .stamps/build.log"; exit 1; }
	@# Byte-compiled once here: where PYTHONDONTWRITEBYTECODE is set (as on our machines) every node compiled the
	@# workspace's modules again at each start, 0.1 CPU s of its 0.4 (compileall writes the caches regardless).
	$(VENV)/bin/python -m compileall -q -j0 $(WS)/src/*/src $(WS)/devel/lib/python3*/site-packages > /dev/null
	@echo "== built: source env.sh to use the workspace"

test: build
	bash tests/run_all.sh

# The fast tier: unit tests and gtests (under 2 minutes on 2 cores); make test runs them too, and the rest.
check: build
	bash tests/run_check.sh

DEMO_SCENARIO ?= scenarios/summit_circle_1ms.yaml
demo: build
	@echo "== demo: one headless landing on the moving Summit XL ($(DEMO_SCENARIO))"
	source env.sh && rosrun landing_eval run_scenario $(DEMO_SCENARIO) --out results/demo
	source env.sh && rosrun landing_eval analyze results/demo/flight.bag --out results/demo/report
	@echo "== report: results/demo/report/report.md (plots beside it), bag: results/demo/flight.bag"

# The shipped suite (scenarios/*.yaml; scenarios/stress/ is not part of it). Exits non-zero when a scenario
# misses its expectation; the table (with the commit and the command line) is written to README.md either way.
# On a Ray cluster: make bench BENCH_ARGS="--ray auto"
BENCH_ARGS ?= --jobs 2
bench: build
	source env.sh && rosrun landing_bench bench_sim
	source env.sh && rosrun landing_eval benchmark scenarios --out results/bench $(BENCH_ARGS) --readme README.md
	@echo "== results table written to README.md (Results section) and results/bench/summary.md"

clean:
	rm -rf build devel install $(STAMPS)
