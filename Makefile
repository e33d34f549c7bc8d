# The targets DuckDB's extension CI (extension-ci-tools, c_api_extensions) calls for a Rust
# extension: configure, debug, release, test_debug, test_release, clean. With the
# extension-ci-tools checkout present (the community-extensions build adds it), its makefiles
# do the work; without it, the same targets run this repository's own scripts.
.PHONY: all configure debug release test test_debug test_release clean clean_all

PROJ_DIR := $(dir $(abspath $(lastword $(MAKEFILE_LIST))))
EXTENSION_NAME=trajdb
# trajdb uses the STABLE C API (v1.2.0, C_STRUCT): one binary loads in DuckDB 1.5 and 2.0
USE_UNSTABLE_C_API=0
TARGET_DUCKDB_VERSION=v1.2.0
CARGO_FLAGS=--no-default-features --features extension $(ARROW_O0)
# arrow (pulled in by duckdb-rs, never run by the extension) unoptimised, as in pyproject.toml
# and scripts/build_extension.sh: a third of the build time
ARROW_O0=$(foreach c,arrow arrow-arith arrow-array arrow-buffer arrow-cast arrow-cmp arrow-data arrow-ord arrow-row arrow-schema arrow-select arrow-string regex regex-automata regex-syntax,--config profile.release.package.$(c).opt-level=0)

all: configure release

ifneq ($(wildcard extension-ci-tools/makefiles/c_api_extensions/base.Makefile),)
include extension-ci-tools/makefiles/c_api_extensions/base.Makefile
include extension-ci-tools/makefiles/c_api_extensions/rust.Makefile

# rust.Makefile runs a bare `cargo build` into ./target; trajdb's default feature is the
# bundled binary, so the library targets are redefined (after the include: these recipes win)
# to build the loadable extension feature.
build_extension_library_debug build_extension_library_release: check_configure
	CARGO_TARGET_DIR=./target cargo build $(if $(findstring release,$@),--release) --lib $(CARGO_FLAGS)
	$(PYTHON_VENV_BIN) -c "from pathlib import Path;Path('$(EXTENSION_BUILD_PATH)/$(if $(findstring release,$@),release,debug)/extension/$(EXTENSION_NAME)').mkdir(parents=True, exist_ok=True)"
	$(PYTHON_VENV_BIN) -c "import shutil;shutil.copyfile('./target/$(if $(findstring release,$@),release,debug)/$(EXTENSION_LIB_FILENAME)', '$(EXTENSION_BUILD_PATH)/$(if $(findstring release,$@),release,debug)/$(EXTENSION_LIB_FILENAME)')"

configure: venv platform extension_version
debug: build_extension_library_debug build_extension_with_metadata_debug
release: build_extension_library_release build_extension_with_metadata_release
test: test_debug
test_debug: test_extension_debug
test_release: test_extension_release
clean: clean_build clean_rust
clean_all: clean_configure clean
else
configure:
	python3 -m venv configure/venv && configure/venv/bin/pip install -q -r requirements-test.txt
debug release:
	scripts/build_extension.sh
test test_debug test_release: release
	configure/venv/bin/python tests/run_slt_python.py trajdb.duckdb_extension
clean:
	rm -f trajdb.duckdb_extension
clean_all: clean
	rm -rf configure
endif
