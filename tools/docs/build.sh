#!/usr/bin/env bash
# Builds the HTML reference: the Python package pardel (Sphinx autodoc, docs/reference/) and the
# public C++ headers, those under include/ folders (Doxygen, docs/reference/Doxyfile), into one
# folder. Exits non-zero on any warning of either tool.
#   tools/docs/build.sh [BUILD_DIR] [OUT_DIR]
# BUILD_DIR (default build) holds the built Python module (target pardel_python); OUT_DIR
# (default BUILD_DIR/docs/html) gets the Sphinx pages, with the Doxygen pages in OUT_DIR/cpp.
# Needs Debian's python3-sphinx and doxygen (tools/install-deps.sh).
#
# Warnings: Sphinx runs with -W --keep-going (every warning reported, then failure) and -E (every
# page read again, so that a docstring changed in the package is rendered and checked). Doxygen
# runs with WARN_AS_ERROR = FAIL_ON_WARNINGS and WARN_IF_DOC_ERROR = YES, so malformed markup in a
# doc comment (an unknown command, an unsupported HTML tag, a bad @param name) fails the build.
# It uses EXTRACT_ALL = YES, so that every declaration of a public header is in the reference,
# commented or not; that also turns off WARN_IF_UNDOCUMENTED, which is NO as well: with
# EXTRACT_ALL = NO it reports about 190 declarations without a comment of their own (members and
# enumerators that their type's comment describes, self-explanatory accessors), none of them
# broken documentation.
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
build="$(cd "${1:-build}" && pwd)"
out="${2:-$build/docs/html}"
mkdir -p "$out"
out="$(cd "$out" && pwd)"
python=/usr/bin/python3  # Debian's, where python3-sphinx lives (a pyenv python3 may lack it)

if [ ! -f "$build/python/pardel/__init__.py" ]; then
  echo "tools/docs/build.sh: $build/python/pardel is missing: build the Python module first" \
       "(cmake --build $build --target pardel_python)" >&2
  exit 1
fi

status=0
# Doxygen, from the repository root (the Doxyfile's paths are relative to it); QUIET = YES, so that
# only its warnings show.
(cd "$root" && { cat docs/reference/Doxyfile
                 echo "OUTPUT_DIRECTORY = $out"
                 echo "HTML_OUTPUT = cpp"; } | doxygen -) || status=1

PYTHONPATH="$build/python${PYTHONPATH:+:$PYTHONPATH}" \
  "$python" -m sphinx -W --keep-going -E -q -b html -d "$build/docs/doctrees" \
  "$root/docs/reference" "$out" || status=1

if [ "$status" -ne 0 ]; then
  echo "tools/docs/build.sh: warnings above (the reference is built with warnings as errors)" >&2
  exit 1
fi
echo "tools/docs/build.sh: $out/index.html"
