# rigid_body_attitude: set-up, run and test without a ROS install.
#
#   make run    create/update .venv, then start the propagation node with the default scene
#   make test   the same, plus the test tools (requirements-test.txt), then run the whole suite
#
# .venv holds Python 3.12 or 3.11 (the versions the ROS 2 Jazzy wheels are built for), the
# pinned ROS 2 Jazzy wheels and tools (requirements.txt), tf2_msgs built from its interface
# definition (interfaces/tf2_msgs, with the build-time wheels of requirements-build.txt, CMake
# and a C/C++ compiler) and this package, installed (not editable) the way colcon lays out an
# ament_python package. Stamp files in .venv make a second run fast: the requirements are
# re-installed when a requirements file changes, tf2_msgs re-built when its interface package
# changes, the package when any of its sources, config or launch files or packaging files change.
#
# The interpreter: the newest of python3.12, then python3.11 (on PATH, else a pyenv install of
# that version), then python3 if it is 3.12 or 3.11; an existing venv keeps the interpreter it
# was made with. `make PYTHON=/path/to/python3.11 ...` chooses one (and re-creates the venv if
# it was made with another version). A second venv: `make test VENV=.venv-3.11 PYTHON=...`.

VENV := .venv
SUPPORTED_PYTHONS := 3.12 3.11
comma := ,
space := $(subst ,, )
PYTHON_VERSION_OF = $(shell $(1) -c 'import sys; print("%d.%d" % sys.version_info[:2])' 2>/dev/null)

# Candidates newest first; one that does not run (a pyenv shim of a version that is not enabled
# says "command not found") or runs another version is passed over.
PYENV_VERSIONS := $(shell pyenv root 2>/dev/null)/versions
# PYTHON_SEARCH narrows the versions looked for (CI: PYTHON_SEARCH=3.11 for the older one).
PYTHON_SEARCH ?= $(SUPPORTED_PYTHONS)
PYTHON_CANDIDATES := $(foreach v,$(PYTHON_SEARCH),python$(v) \
	$(lastword $(sort $(wildcard $(PYENV_VERSIONS)/$(v).*/bin/python$(v))))) python3
find_python = $(firstword $(foreach c,$(PYTHON_CANDIDATES),$(if $(filter \
	$(PYTHON_SEARCH),$(call PYTHON_VERSION_OF,$(c))),$(shell command -v $(c)))))

# The venv's interpreter version is recorded as $(VENV)/.python-<version>.
VENV_PYTHON_VERSION := $(patsubst $(VENV)/.python-%,%,$(firstword $(foreach \
	v,$(PYTHON_SEARCH),$(wildcard $(VENV)/.python-$(v)))))
ifeq ($(origin PYTHON),undefined)
ifeq ($(VENV_PYTHON_VERSION),)
PYTHON := $(find_python)
endif
endif
PYTHON_VERSION := $(if $(PYTHON),$(call PYTHON_VERSION_OF,$(PYTHON)),$(VENV_PYTHON_VERSION))
VENV_MARKER := $(VENV)/.python-$(PYTHON_VERSION)

VENV_PYTHON := $(VENV)/bin/python
REQUIREMENTS := requirements.txt requirements-build.txt
REQUIREMENTS_STAMP := $(VENV)/.requirements.stamp
TEST_REQUIREMENTS := requirements-test.txt
TEST_REQUIREMENTS_STAMP := $(VENV)/.test-requirements.stamp
PACKAGE_STAMP := $(VENV)/.package.stamp
STAGE_DIR := $(VENV)/.stage
PACKAGE := rigid_body_attitude
PIP := $(VENV_PYTHON) -m pip --disable-pip-version-check --no-input
PIP_INSTALL := $(PIP) install --progress-bar off

# What the installed package is built from. Directories are listed too: their time stamps change
# when a file is added or removed.
PACKAGE_FILES := setup.py setup.cfg package.xml LICENSE resource/$(PACKAGE) \
	$(shell find $(PACKAGE) config launch scripts/launchers -name __pycache__ -prune \
		-o ! -name '*.pyc' -print 2>/dev/null)

# tf2_msgs has no wheel: it is built from its interface package against the venv's ROS 2 wheels
# (CMake and a C/C++ compiler from the system) and installed into the venv prefix, as colcon
# would install it. A ROS install uses its own tf2_msgs (interfaces/ holds a COLCON_IGNORE).
TF2_MSGS_SOURCE := interfaces/tf2_msgs
TF2_MSGS_STAMP := $(VENV)/.tf2_msgs.stamp
TF2_MSGS_BUILD := $(VENV)/.tf2_msgs-build
TF2_MSGS_FILES := $(shell find $(TF2_MSGS_SOURCE) -print 2>/dev/null)
TF2_MSGS_CMAKE_INCLUDE := $(abspath $(TF2_MSGS_SOURCE))/cmake/strip_foreign_include_dirs.cmake
VENV_PREFIX := $(abspath $(VENV))
BUILD_ENV := env PATH="$(VENV_PREFIX)/bin:$$PATH"
BUILD_JOBS := $(shell nproc 2>/dev/null || echo 2)

# The node starts with config/params.yaml (as installed) when the package ships one. Extra
# arguments: make run ARGS='--ros-args -p name:=value'.
PARAMS_FILE := $(abspath $(VENV))/share/$(PACKAGE)/config/params.yaml
RUN_ARGS := $(if $(wildcard config/params.yaml),--ros-args --params-file $(PARAMS_FILE))
ARGS ?=

# Every command below sees the venv as the only ament prefix and a discovery range limited to
# this machine (ROS_DOMAIN_ID is left to the user). A sourced ROS install's variables would mix
# its modules and libraries (another build of ROS 2) into the venv's, so they are not passed on.
export AMENT_PREFIX_PATH := $(abspath $(VENV))
export ROS_AUTOMATIC_DISCOVERY_RANGE := LOCALHOST
unexport PYTHONPATH LD_LIBRARY_PATH RMW_IMPLEMENTATION ROS_LOCALHOST_ONLY
unexport CMAKE_PREFIX_PATH COLCON_PREFIX_PATH AMENT_CURRENT_PREFIX
unexport _ROS_WHEELS_BOOTSTRAP_COMPLETE

.PHONY: run test install lint clean help
.DEFAULT_GOAL := help

help:
	@echo 'make run    start the propagation node (default scene) from .venv'
	@echo 'make test   run the whole test suite against the package installed in .venv'
	@echo 'make lint   flake8 only'
	@echo 'make clean  remove .venv'
	@echo 'Python 3.12 or 3.11 (the newest found; make PYTHON=... chooses), venv: make VENV=...'

run: install
	$(VENV_PYTHON) scripts/ros2run $(PACKAGE) propagation_node $(RUN_ARGS) $(ARGS)

# -P: the working directory is not put on sys.path, so the tests import the installed package.
# A subset: make test TESTS=test/test_packaging.py ARGS='-x -q'.
TESTS ?= test
test: install $(TEST_REQUIREMENTS_STAMP)
	$(VENV_PYTHON) -P -m pytest $(TESTS) $(ARGS)

# The same paths as test/test_flake8.py.
lint: install $(TEST_REQUIREMENTS_STAMP)
	$(VENV_PYTHON) -m flake8 $(PACKAGE) test $(wildcard bench) launch setup.py scripts/ros2run

install: $(TF2_MSGS_STAMP) $(PACKAGE_STAMP)

# Made (or re-made, --clear) when the venv has no marker of the chosen Python version.
$(VENV_MARKER):
	@test -n "$(PYTHON)" || { echo 'error: no Python $(subst $(space),$(comma) ,$(PYTHON_SEARCH))' \
		'found ($(PYTHON_CANDIDATES)): make PYTHON=/path/to/python3.12 ...' >&2; exit 1; }
	@test -n "$(filter $(SUPPORTED_PYTHONS),$(PYTHON_VERSION))" || { \
		echo 'error: $(PYTHON) $(if $(PYTHON_VERSION),is Python $(PYTHON_VERSION),does not run); the ROS 2' \
		'Jazzy wheels need Python 3.12 or 3.11: make PYTHON=/path/to/python3.12 ...' >&2; \
		exit 1; }
	$(PYTHON) -m venv --clear $(VENV)
	touch $@

$(REQUIREMENTS_STAMP): $(REQUIREMENTS) $(VENV_MARKER)
	$(PIP_INSTALL) $(addprefix -r ,$(REQUIREMENTS))
	touch $@

# The test tools, on top of what running needs (make test, make lint).
$(TEST_REQUIREMENTS_STAMP): $(TEST_REQUIREMENTS) $(REQUIREMENTS_STAMP)
	$(PIP_INSTALL) -r $(TEST_REQUIREMENTS) -c requirements.txt
	touch $@

# The project include drops the include folders of the wheels' build machine from the imported
# targets (see the file). The build folder is removed afterwards.
$(TF2_MSGS_STAMP): $(REQUIREMENTS_STAMP) $(TF2_MSGS_FILES)
	rm -rf $(TF2_MSGS_BUILD)
	$(BUILD_ENV) cmake -S $(TF2_MSGS_SOURCE) -B $(TF2_MSGS_BUILD) -Wno-dev \
		-DCMAKE_BUILD_TYPE=Release -DBUILD_TESTING=OFF \
		-DCMAKE_INSTALL_PREFIX=$(VENV_PREFIX) -DCMAKE_PREFIX_PATH=$(VENV_PREFIX) \
		-DPython3_EXECUTABLE=$(VENV_PREFIX)/bin/python -DCMAKE_INSTALL_MESSAGE=NEVER \
		-DCMAKE_PROJECT_tf2_msgs_INCLUDE=$(TF2_MSGS_CMAKE_INCLUDE)
	$(BUILD_ENV) cmake --build $(TF2_MSGS_BUILD) --parallel $(BUILD_JOBS)
	$(BUILD_ENV) cmake --install $(TF2_MSGS_BUILD)
	rm -rf $(TF2_MSGS_BUILD)
	touch $@

# A clean copy is built, so nothing is written into the source tree and no stale build/ output
# (a deleted module, say) can reach the wheel. --force-reinstall removes the previous install.
$(PACKAGE_STAMP): $(REQUIREMENTS_STAMP) $(PACKAGE_FILES)
	rm -rf $(STAGE_DIR)
	mkdir -p $(STAGE_DIR)
	cp -R setup.py setup.cfg package.xml LICENSE resource config launch scripts $(PACKAGE) \
		$(STAGE_DIR)/
	find $(STAGE_DIR) -name __pycache__ -prune -exec rm -rf {} +
	$(PIP_INSTALL) --no-deps --no-build-isolation --use-pep517 --force-reinstall $(STAGE_DIR)
	rm -rf $(STAGE_DIR)
	touch $@

clean:
	rm -rf $(VENV)
