// The registry of models whose generated kernels are compiled into test_codegen_kernels.
#ifndef PARDEL_TESTS_CODEGEN_GENERATED_MODELS_HPP
#define PARDEL_TESTS_CODEGEN_GENERATED_MODELS_HPP

#include "pardel/kernel_abi.h"

/** A compiled model and the .lag file it was generated from. */
struct GeneratedModel {
  const pardel_model* model;
  const char* lag_path;     ///< absolute path of the .lag
  const char* source_name;  ///< the name the generator recorded (relative to the project root)
};

extern const GeneratedModel kGeneratedModels[];
extern const int kGeneratedModelCount;

#endif  // PARDEL_TESTS_CODEGEN_GENERATED_MODELS_HPP
