# Builds and runs the project in project/ against pardel, one of two ways (MODE):
#   subdirectory  the project includes the pardel checkout SOURCE_DIR with add_subdirectory;
#   installed     this build (BUILD_DIR) is installed into WORK_DIR/prefix with `cmake --install`
#                 (component cxx) and the project finds it with find_package(pardel).
# The project is configured in WORK_DIR/build with the outer build's GENERATOR, MAKE_PROGRAM,
# C and C++ compilers, BUILD_TYPE and flags. With PYTHON (the interpreter of the Python module,
# when the build has it), the installed mode also installs the module (component python) and runs
# check_installed_python.py against the prefix. Run by ctest (tests/package/CMakeLists.txt).
cmake_policy(VERSION 3.20)

function(run what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${what} failed (${rc}): ${ARGN}")
  endif()
endfunction()

set(project_dir "${CMAKE_CURRENT_LIST_DIR}/project")
set(build "${WORK_DIR}/build")
set(prefix "${WORK_DIR}/prefix")
set(configure_args
  -S "${project_dir}" -B "${build}" -G "${GENERATOR}"
  "-DCMAKE_MAKE_PROGRAM=${MAKE_PROGRAM}"
  "-DCMAKE_C_COMPILER=${C_COMPILER}" "-DCMAKE_CXX_COMPILER=${CXX_COMPILER}"
  "-DCMAKE_BUILD_TYPE=${BUILD_TYPE}"
  "-DCMAKE_C_FLAGS=${C_FLAGS}" "-DCMAKE_CXX_FLAGS=${CXX_FLAGS}"
  "-DCMAKE_EXE_LINKER_FLAGS=${EXE_LINKER_FLAGS}")

if(MODE STREQUAL "subdirectory")
  list(APPEND configure_args "-DPARDEL_SOURCE_DIR=${SOURCE_DIR}")
elseif(MODE STREQUAL "installed")
  file(REMOVE_RECURSE "${prefix}")
  run("cmake --install" "${CMAKE_COMMAND}" --install "${BUILD_DIR}" --prefix "${prefix}" --component cxx)
  list(APPEND configure_args "-DCMAKE_PREFIX_PATH=${prefix}" "-DPARDEL_SOURCE_DIR=")
else()
  message(FATAL_ERROR "MODE must be subdirectory or installed, not '${MODE}'")
endif()

# A fresh configuration each time (the installed prefix is new); objects are rebuilt only when
# their inputs changed.
run("configuring the project" "${CMAKE_COMMAND}" --fresh ${configure_args})
run("building the project" "${CMAKE_COMMAND}" --build "${build}" --target projectile_test projectile_scene)
set(program "${build}/projectile_test")
run("the program" "${program}")
file(REMOVE_RECURSE "${WORK_DIR}/scene_out")
run("the scene program (pardel::app)" "${build}/projectile_scene" "${project_dir}/projectile.toml"
    "${WORK_DIR}/scene_out")

if(MODE STREQUAL "installed" AND PYTHON)
  run("cmake --install (python)" "${CMAKE_COMMAND}" --install "${BUILD_DIR}" --prefix "${prefix}" --component python)
  file(GLOB_RECURSE init "${prefix}/__init__.py")
  list(FILTER init INCLUDE REGEX "/pardel/__init__\\.py$")
  list(LENGTH init count)
  if(NOT count EQUAL 1)
    message(FATAL_ERROR "expected one installed package pardel under ${prefix}, found: ${init}")
  endif()
  get_filename_component(package "${init}" DIRECTORY)
  get_filename_component(site "${package}" DIRECTORY)
  run("the installed Python module"
      "${CMAKE_COMMAND}" -E env "PYTHONPATH=${site}" "PARDEL_CACHE_DIR=${WORK_DIR}/model-cache" --
      "${PYTHON}" "${CMAKE_CURRENT_LIST_DIR}/check_installed_python.py" "${prefix}" "${project_dir}/projectile.lag")
endif()
