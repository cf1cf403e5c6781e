# rigid_body_attitude: set-up, run and test without a ROS install.
#
#   make run    create/update .venv, then start the propagation node with the default scene
#   make test   create/update .venv, then run the whole test suite
#
# .venv holds Python 3.11, the pinned ROS 2 Jazzy wheels and tools (requirements.txt) and this
# package, installed (not editable) the way colcon lays out an ament_python package. Stamp files
# in .venv make a second run fast: the requirements are re-installed when requirements.txt
# changes, the package when any of its sources, config files or packaging files change.

PYTHON ?= $(shell command -v python3.11 2>/dev/null || command -v python3 2>/dev/null)
VENV := .venv
VENV_PYTHON := $(VENV)/bin/python
REQUIREMENTS_STAMP := $(VENV)/.requirements.stamp
PACKAGE_STAMP := $(VENV)/.package.stamp
STAGE_DIR := $(VENV)/.stage
PACKAGE := rigid_body_attitude
PIP := $(VENV_PYTHON) -m pip --disable-pip-version-check --no-input
PIP_INSTALL := $(PIP) install --progress-bar off

# What the installed package is built from. Directories are listed too: their time stamps change
# when a file is added or removed.
PACKAGE_FILES := setup.py setup.cfg package.xml LICENSE resource/$(PACKAGE) \
	$(shell find $(PACKAGE) config scripts/launchers -name __pycache__ -prune \
		-o ! -name '*.pyc' -print 2>/dev/null)

# The node starts with config/params.yaml (as installed) when the package ships one. Extra
# arguments: make run ARGS='--ros-args -p name:=value'.
PARAMS_FILE := $(abspath $(VENV))/share/$(PACKAGE)/config/params.yaml
RUN_ARGS := $(if $(wildcard config/params.yaml),--ros-args --params-file $(PARAMS_FILE))
ARGS ?=

# Every command below sees the venv as the only ament prefix and a discovery range limited to
# this machine (ROS_DOMAIN_ID is left to the user). A sourced ROS install's variables would mix
# its Python 3.12 modules and libraries into the venv's, so they are not passed on.
export AMENT_PREFIX_PATH := $(abspath $(VENV))
export ROS_AUTOMATIC_DISCOVERY_RANGE := LOCALHOST
unexport PYTHONPATH LD_LIBRARY_PATH RMW_IMPLEMENTATION ROS_LOCALHOST_ONLY
unexport _ROS_WHEELS_BOOTSTRAP_COMPLETE

.PHONY: run test install lint clean help
.DEFAULT_GOAL := help

help:
	@echo 'make run    start the propagation node (default scene) from .venv'
	@echo 'make test   run the whole test suite against the package installed in .venv'
	@echo 'make lint   flake8 only'
	@echo 'make clean  remove .venv'

run: install
	$(VENV_PYTHON) scripts/ros2run $(PACKAGE) propagation_node $(RUN_ARGS) $(ARGS)

# -P: the working directory is not put on sys.path, so the tests import the installed package.
# A subset: make test TESTS=test/test_packaging.py ARGS='-x -q'.
TESTS ?= test
test: install
	$(VENV_PYTHON) -P -m pytest $(TESTS) $(ARGS)

# The same paths as test/test_flake8.py.
lint: install
	$(VENV_PYTHON) -m flake8 $(PACKAGE) test $(wildcard bench) setup.py scripts/ros2run

install: $(PACKAGE_STAMP)

$(VENV_PYTHON):
	@test -n "$(PYTHON)" || { echo 'error: no python3.11 or python3 on PATH' >&2; exit 1; }
	@$(PYTHON) -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))' || { \
		echo "error: $(PYTHON) is Python `$(PYTHON) -c 'import platform; \
		print(platform.python_version())'`; the ROS 2 Jazzy wheels need Python 3.11:" \
		"make PYTHON=/path/to/python3.11 ..." >&2; exit 1; }
	$(PYTHON) -m venv --clear $(VENV)

$(REQUIREMENTS_STAMP): requirements.txt | $(VENV_PYTHON)
	$(PIP_INSTALL) -r requirements.txt
	touch $@

# A clean copy is built, so nothing is written into the source tree and no stale build/ output
# (a deleted module, say) can reach the wheel. --force-reinstall removes the previous install.
$(PACKAGE_STAMP): $(REQUIREMENTS_STAMP) $(PACKAGE_FILES)
	rm -rf $(STAGE_DIR)
	mkdir -p $(STAGE_DIR)
	cp -R setup.py setup.cfg package.xml LICENSE resource config scripts $(PACKAGE) $(STAGE_DIR)/
	find $(STAGE_DIR) -name __pycache__ -prune -exec rm -rf {} +
	$(PIP_INSTALL) --no-deps --no-build-isolation --use-pep517 --force-reinstall $(STAGE_DIR)
	rm -rf $(STAGE_DIR)
	touch $@

clean:
	rm -rf $(VENV)
