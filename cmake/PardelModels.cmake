# pardel_add_model(<target> <file.lag> [KERNELS_ONLY] [ALLOW_SINGULAR] [DEVICE])
#
# Generates the kernels of a .lag model at build time (pardel-gen, then the Jinja2 render step)
# and compiles them into <target>, which is linked to pardel::runtime (pardel::solve and the rest of
# pardel/pardel.hpp); KERNELS_ONLY links only the kernel ABI (the bundled-model library uses it).
# The generated header <model>.hpp is put on <target>'s include
# path; the model's descriptor is the C symbol `<model>_model` (see pardel/kernel_abi.h).
# pardel-gen refuses a model that is not regular (W = d2L/dq^(order)dq^(order) singular everywhere,
# or a discretization such as trapezoid(alpha=0)); ALLOW_SINGULAR generates it with a warning
# (pardel-gen --allow-singular), for a model that is degenerate on purpose.
# DEVICE also compiles the model for the CUDA device solvers (pardel::cuda, docs/gpu.md) and links
# <target> to them: its discretizations with device kernels are then solved by
# solve_batch_cuda and Options::device = cuda like the bundled models of PARDEL_DEVICE_MODELS. That
# needs pardel's build tree (or add_subdirectory) with PARDEL_WITH_CUDA; where pardel has no CUDA
# the keyword is ignored with a note, and the model is on the host only.
# Editing the .lag, the generator or its templates regenerates exactly that model.
#
# Without GiNaC (PARDEL_REGENERATE=OFF) the committed copy under generated/ is compiled instead;
# that works only for the bundled models.
#
# The same file serves pardel's own build (and add_subdirectory(pardel)) and an installed pardel
# (find_package(pardel), through pardel-config.cmake). Either way the generator is the executable
# target pardel::pardel-gen, and PARDEL_RENDER_SCRIPT, PARDEL_TEMPLATES, PARDEL_PYTHON,
# PARDEL_GENERATED_DIR and PARDEL_REGENERATE say where the rest is; an installed pardel sets them
# to its installed copies before including this file.
include_guard(GLOBAL)

# Whether the C++ compiler finds quadmath.h: the generated kernels then use __float128 and
# libquadmath for their extended-precision kernels (GCC), and long double otherwise (clang).
include(CheckIncludeFileCXX)
check_include_file_cxx(quadmath.h PARDEL_HAVE_QUADMATH_H)

if(TARGET pardel-gen AND NOT TARGET pardel::pardel-gen)
  add_executable(pardel::pardel-gen ALIAS pardel-gen)
endif()
set(PARDEL_DEVICE_MODEL_SCRIPT "${CMAKE_CURRENT_LIST_DIR}/PardelDeviceModel.cmake" CACHE INTERNAL
    "Writes a model's device source (pardel_add_model(... DEVICE))")
if(NOT DEFINED PARDEL_GENERATED_DIR)
  set(PARDEL_GENERATED_DIR "${PROJECT_SOURCE_DIR}/generated" CACHE INTERNAL
      "Committed generated kernels of the bundled models")
endif()

# Reads the model name from the .lag's `model NAME` line (the file's stem if there is none: the
# generator then reports the missing line at build time).
function(pardel_lag_model_name lag out_var)
  file(STRINGS "${lag}" _model_lines REGEX "^[ \t]*model[ \t]+[A-Za-z_][A-Za-z0-9_]*")
  if(_model_lines)
    list(GET _model_lines 0 _line)
    string(REGEX REPLACE "^[ \t]*model[ \t]+([A-Za-z_][A-Za-z0-9_]*).*$" "\\1" _name "${_line}")
  else()
    get_filename_component(_name "${lag}" NAME_WE)
  endif()
  set(${out_var} "${_name}" PARENT_SCOPE)
endfunction()

# The path of a file relative to the project root when inside it (recorded in the banner).
function(pardel_source_name file out_var)
  file(RELATIVE_PATH _rel "${PROJECT_SOURCE_DIR}" "${file}")
  if(_rel MATCHES "^\\.\\./")
    get_filename_component(_rel "${file}" NAME)
  endif()
  set(${out_var} "${_rel}" PARENT_SCOPE)
endfunction()

function(pardel_add_model target lag)
  cmake_parse_arguments(PARSE_ARGV 2 _arg "KERNELS_ONLY;ALLOW_SINGULAR;DEVICE" "" "")
  get_filename_component(lag "${lag}" ABSOLUTE)
  if(NOT EXISTS "${lag}")
    message(FATAL_ERROR "pardel_add_model: no such file: ${lag}")
  endif()
  set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS "${lag}")
  pardel_lag_model_name("${lag}" model)
  pardel_source_name("${lag}" source_name)

  if(PARDEL_REGENERATE AND TARGET pardel::pardel-gen)
    # The generator as a dependency: the target itself in pardel's build (built first), the
    # installed executable (a file) otherwise.
    get_target_property(gen pardel::pardel-gen ALIASED_TARGET)
    if(NOT gen)
      set(gen pardel::pardel-gen)
    endif()
    set(out_dir "${CMAKE_CURRENT_BINARY_DIR}/pardel_generated")
    set(ir "${out_dir}/${model}.ir.json")
    set(gen_flags "")
    if(_arg_ALLOW_SINGULAR)
      set(gen_flags --allow-singular)
    endif()
    add_custom_command(
      OUTPUT "${out_dir}/${model}.hpp" "${out_dir}/${model}.cpp"
      COMMAND ${CMAKE_COMMAND} -E make_directory "${out_dir}"
      COMMAND $<TARGET_FILE:pardel::pardel-gen> "${lag}" -o "${ir}" --source-name "${source_name}" ${gen_flags}
      COMMAND "${PARDEL_PYTHON}" "${PARDEL_RENDER_SCRIPT}" "${ir}" --out-dir "${out_dir}"
      DEPENDS "${lag}" ${gen} "${PARDEL_RENDER_SCRIPT}" ${PARDEL_TEMPLATES}
      COMMENT "pardel-gen: ${source_name} -> ${model}.hpp, ${model}.cpp"
      VERBATIM)
  else()
    set(out_dir "${PARDEL_GENERATED_DIR}")
    if(NOT EXISTS "${out_dir}/${model}.cpp")
      message(FATAL_ERROR "pardel_add_model: ${source_name} needs pardel-gen (GiNaC was not found, "
                          "or PARDEL_REGENERATE is OFF) and has no committed copy in ${out_dir}.")
    endif()
  endif()
  target_sources(${target} PRIVATE "${out_dir}/${model}.cpp")
  target_include_directories(${target} PUBLIC "$<BUILD_INTERFACE:${out_dir}>")
  target_link_libraries(${target} PUBLIC pardel::kernel_abi)
  # The extended-precision kernels (grad_extended) call libquadmath (sinq, ...) where the compiler
  # finds quadmath.h (GCC); elsewhere they compute in long double and need no library.
  if(PARDEL_HAVE_QUADMATH_H)
    target_link_libraries(${target} PUBLIC quadmath)
  endif()
  if(NOT _arg_KERNELS_ONLY)
    target_link_libraries(${target} PUBLIC pardel::runtime)
  endif()
  if(_arg_DEVICE)
    pardel_add_device_model(${target} ${model} "${out_dir}" "${source_name}")
  endif()
  set_property(TARGET ${target} APPEND PROPERTY PARDEL_MODELS "${model}")
  set_property(TARGET ${target} APPEND PROPERTY PARDEL_GENERATED_FILES
               "${out_dir}/${model}.hpp" "${out_dir}/${model}.cpp")
endfunction()

# The device copy of a model that pardel_add_model generated into out_dir (its DEVICE keyword).
function(pardel_add_device_model target model out_dir source_name)
  if(NOT TARGET pardel::cuda OR NOT PARDEL_CUDA_SOURCE_DIR)
    message(STATUS "pardel_add_model(${target} ${source_name} DEVICE): pardel has no CUDA device solvers "
                   "(PARDEL_WITH_CUDA off, or an installed pardel); the model is on the host only")
    return()
  endif()
  set(device_source "${CMAKE_CURRENT_BINARY_DIR}/pardel_generated/${model}_device.cu")
  add_custom_command(
    OUTPUT "${device_source}"
    COMMAND ${CMAKE_COMMAND} -DMODEL=${model} -DCPP=${out_dir}/${model}.cpp -DHPP=${out_dir}/${model}.hpp
            -DOUT=${device_source} -DREGISTRATION=static -P "${PARDEL_DEVICE_MODEL_SCRIPT}"
    DEPENDS "${out_dir}/${model}.cpp" "${out_dir}/${model}.hpp" "${PARDEL_DEVICE_MODEL_SCRIPT}"
    COMMENT "pardel: ${model} for the device"
    VERBATIM)
  target_sources(${target} PRIVATE "${device_source}")
  set_source_files_properties("${device_source}" PROPERTIES
    INCLUDE_DIRECTORIES "${PARDEL_CUDA_SOURCE_DIR};${out_dir}"
    COMPILE_DEFINITIONS "PARDEL_CUDA_MIN_BLOCKS=${PARDEL_CUDA_MIN_BLOCKS}")
  target_link_libraries(${target} PUBLIC pardel::cuda)
endfunction()
