# The CUDA source of one model for the device solvers (pardel::cuda, runtime/cuda/): its generated
# kernels compiled as CUDA, with every extern symbol its header declares (kernels, the model's
# descriptor) renamed with the prefix pardel_device_ so that a program links it beside the host
# build of the same model, and the launch loop of each discretization whose sweep kernel the header
# declares PARDEL_HD (batch_device.cuh: the sweeps and Newton), the model's dimension a constant.
#
#   pardel_device_model_source(<model> <generated .cpp> <generated .hpp> <output .cu> <registration>)
#
# <registration> "function": the source defines pardel_cuda_register_<model>(entries), which the
# device registry of the bundled models (PARDEL_DEVICE_MODELS) calls; "static": a static object
# adds the model to the registry when the program starts (pardel_add_model(... DEVICE)).
#
# Called at configure time for the bundled models (runtime/cuda/CMakeLists.txt, whose generated
# sources are committed) and as a script at build time for models added with
# pardel_add_model(... DEVICE), whose sources exist only then:
#   cmake -DMODEL=m -DCPP=m.cpp -DHPP=m.hpp -DOUT=m_device.cu -DREGISTRATION=static -P PardelDeviceModel.cmake
include_guard(GLOBAL)

function(pardel_device_model_source model cpp hpp out registration)
  # The model's dimension: the sixth value of its pardel_model initializer (abi, name, source,
  # order, ncoords, dim, ...; pardel/kernel_abi.h).
  file(READ "${cpp}" _text)
  string(REGEX MATCH "const pardel_model ${model}_model = {[^}]*}" _init "${_text}")
  string(REGEX REPLACE "[ \n]+" "" _init "${_init}")
  string(REGEX MATCH "{[^}]*" _init "${_init}")
  string(SUBSTRING "${_init}" 1 -1 _init)
  string(REPLACE "," ";" _fields "${_init}")
  list(LENGTH _fields _count)
  set(_dim "")
  if(_count GREATER 5)
    list(GET _fields 5 _dim)
  endif()
  if(NOT _dim MATCHES "^[0-9]+$")
    message(FATAL_ERROR "cannot read the dimension of ${model} from ${cpp}")
  endif()
  # Every extern symbol its header declares, renamed in the device source.
  file(STRINGS "${hpp}" _decls REGEX "^(PARDEL_HD )?(void|double) [A-Za-z0-9_]+\\(|^extern const pardel_model ")
  set(_renames "")
  foreach(_decl IN LISTS _decls)
    string(REGEX REPLACE "^(PARDEL_HD )?(void|double|extern const pardel_model) ([A-Za-z0-9_]+).*" "\\3" _name "${_decl}")
    string(APPEND _renames "#define ${_name} pardel_device_${_name}\n")
  endforeach()
  # Its discretizations with device code: the PARDEL_HD sweep kernels its header declares.
  file(STRINGS "${hpp}" _lines REGEX "^PARDEL_HD void [A-Za-z0-9_]+_sweep\\(")
  set(_body "")
  set(_adds "")
  foreach(_line IN LISTS _lines)
    string(REGEX REPLACE "^PARDEL_HD void ([A-Za-z0-9_]+)_sweep\\(.*" "\\1" _symbol "${_line}")
    string(APPEND _body
      "struct ${_symbol}_device {\n"
      "  PARDEL_HD static void sweep(double h, double t0, double t1, const double* q0, const double* q1, const double* p,\n"
      "                              double* D1, double* D2, double* D11, double* D22) {\n"
      "    ${_symbol}_sweep(h, t0, t1, q0, q1, p, D1, D2, D11, D22);\n"
      "  }\n"
      "  PARDEL_HD static void full(double h, double t0, double t1, const double* q0, const double* q1, const double* p,\n"
      "                             double* Ld, double* D1, double* D2, double* D11, double* D12, double* D22) {\n"
      "    ${_symbol}_full(h, t0, t1, q0, q1, p, Ld, D1, D2, D11, D12, D22);\n"
      "  }\n"
      "};\n")
    string(APPEND _adds
      "  pardel::cuda_detail::add_entry(entries, ${model}_model, ${_symbol}_sweep,\n"
      "                                 &pardel::cuda_detail::run_batch<${_symbol}_device, ${_dim}>,\n"
      "                                 &pardel::cuda_detail::run_newton_batch<${_symbol}_device, ${_dim}>);\n")
  endforeach()
  if(registration STREQUAL "static")
    set(_registration
      "\nnamespace {\n"
      "const pardel::cuda_detail::DeviceRegistration pardel_cuda_registration_${model}(&pardel_cuda_register_${model});\n"
      "}  // namespace\n")
  elseif(registration STREQUAL "function")
    set(_registration "")
  else()
    message(FATAL_ERROR "pardel_device_model_source: registration must be function or static, not '${registration}'")
  endif()
  set(_content
"// The model ${model} (dimension ${_dim}) on the device: its generated kernels compiled as CUDA,
// their extern symbols renamed, and the launch loop of each discretization. Written by
// cmake/PardelDeviceModel.cmake.
${_renames}#include \"${cpp}\"
#include \"batch_device.cuh\"

namespace {
${_body}}  // namespace

void pardel_cuda_register_${model}(std::vector<pardel::cuda_detail::DeviceEntry>& entries) {
${_adds}}
${_registration}")
  # At configure time written only when it changes, so that an unchanged model is not compiled
  # again; at build time always (the build step that runs this has an older output to replace).
  set(_old "")
  if(EXISTS "${out}" AND NOT CMAKE_SCRIPT_MODE_FILE)
    file(READ "${out}" _old)
  endif()
  if(NOT _old STREQUAL _content)
    file(WRITE "${out}" "${_content}")
  endif()
endfunction()

if(CMAKE_SCRIPT_MODE_FILE AND CMAKE_SCRIPT_MODE_FILE STREQUAL CMAKE_CURRENT_LIST_FILE)
  pardel_device_model_source("${MODEL}" "${CPP}" "${HPP}" "${OUT}" "${REGISTRATION}")
endif()
