# What `cmake --install` puts under the prefix, and the CMake package that find_package(pardel)
# reads there:
#   include/pardel/                    the public headers (pardel.hpp, kernel_abi.h, ...; not cuda.hpp:
#                                      pardel::cuda is not installed)
#   include/pardel/app/                the headers of pardel::app (scenes, outputs, sweeps)
#   lib/libpardel_*.a                  pardel::runtime, pardel::mpi, pardel::app, pardel::bundled_models
#   bin/pardel-gen                     the code generator (when GiNaC was found)
#   share/pardel/codegen/              render.py and its templates
#   share/pardel/generated/            the committed kernels of the bundled models
#   lib/cmake/pardel/                  pardel-config.cmake, its version file, the exported targets
#                                      and PardelModels.cmake (pardel_add_model)
# All in the install component `cxx` (the Python module is the component `python`, python/).
# Included by the top-level CMakeLists.txt once every target exists.
include_guard(GLOBAL)
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(PARDEL_INSTALL_CMAKEDIR "${CMAKE_INSTALL_LIBDIR}/cmake/pardel" CACHE STRING
    "Where `cmake --install` puts pardel's CMake package, relative to CMAKE_INSTALL_PREFIX")
set(PARDEL_INSTALL_DATADIR "${CMAKE_INSTALL_DATADIR}/pardel")

# Installed targets are named pardel::<EXPORT_NAME>, as their aliases in the build tree.
target_include_directories(pardel_kernel_abi INTERFACE $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
set_target_properties(pardel_kernel_abi PROPERTIES EXPORT_NAME kernel_abi)
set_target_properties(pardel_runtime PROPERTIES EXPORT_NAME runtime)
set(_pardel_export_targets pardel_kernel_abi pardel_runtime)
if(TARGET pardel_mpi)
  set_target_properties(pardel_mpi PROPERTIES EXPORT_NAME mpi)
  list(APPEND _pardel_export_targets pardel_mpi)
endif()
set(PARDEL_INSTALL_APP OFF)
if(TARGET pardel_app)
  set_target_properties(pardel_app PROPERTIES EXPORT_NAME app)
  list(APPEND _pardel_export_targets pardel_app)
  set(PARDEL_INSTALL_APP ON)
endif()
if(TARGET pardel_bundled_models)
  set_target_properties(pardel_bundled_models PROPERTIES EXPORT_NAME bundled_models)
  list(APPEND _pardel_export_targets pardel_bundled_models)
endif()
if(TARGET pardel-gen)
  set_target_properties(pardel-gen PROPERTIES EXPORT_NAME pardel-gen)
  list(APPEND _pardel_export_targets pardel-gen)
endif()

install(TARGETS ${_pardel_export_targets} EXPORT pardelTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT cxx
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT cxx
        RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT cxx)
# pardel/cuda.hpp stays out: pardel::cuda (the device solvers) is a build-tree target only, and an
# installed header without its library would not link.
install(DIRECTORY ${PROJECT_SOURCE_DIR}/runtime/include/pardel DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
        COMPONENT cxx PATTERN "cuda.hpp" EXCLUDE)
if(PARDEL_INSTALL_APP)
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/app/include/pardel DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
          COMPONENT cxx)
endif()
install(FILES ${PARDEL_RENDER_SCRIPT} DESTINATION ${PARDEL_INSTALL_DATADIR}/codegen COMPONENT cxx)
get_filename_component(_pardel_codegen_dir "${PARDEL_RENDER_SCRIPT}" DIRECTORY)
install(DIRECTORY ${_pardel_codegen_dir}/templates DESTINATION ${PARDEL_INSTALL_DATADIR}/codegen
        COMPONENT cxx FILES_MATCHING PATTERN "*.j2")
install(DIRECTORY ${PARDEL_GENERATED_DIR}/ DESTINATION ${PARDEL_INSTALL_DATADIR}/generated
        COMPONENT cxx FILES_MATCHING PATTERN "*.hpp" PATTERN "*.cpp")
install(EXPORT pardelTargets NAMESPACE pardel:: FILE pardel-targets.cmake
        DESTINATION ${PARDEL_INSTALL_CMAKEDIR} COMPONENT cxx)
install(FILES ${PROJECT_SOURCE_DIR}/cmake/PardelModels.cmake DESTINATION ${PARDEL_INSTALL_CMAKEDIR} COMPONENT cxx)

# Paths the config file sets, relative to the prefix (the package is relocatable).
set(PARDEL_INSTALL_CODEGENDIR "${PARDEL_INSTALL_DATADIR}/codegen")
set(PARDEL_INSTALL_GENERATEDDIR "${PARDEL_INSTALL_DATADIR}/generated")
configure_package_config_file(
  ${PROJECT_SOURCE_DIR}/cmake/pardel-config.cmake.in
  ${PROJECT_BINARY_DIR}/pardel-config.cmake
  INSTALL_DESTINATION ${PARDEL_INSTALL_CMAKEDIR}
  PATH_VARS PARDEL_INSTALL_CODEGENDIR PARDEL_INSTALL_GENERATEDDIR)
# 0.x: a minor version may change the API.
write_basic_package_version_file(${PROJECT_BINARY_DIR}/pardel-config-version.cmake
                                 VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/pardel-config.cmake ${PROJECT_BINARY_DIR}/pardel-config-version.cmake
        DESTINATION ${PARDEL_INSTALL_CMAKEDIR} COMPONENT cxx)
