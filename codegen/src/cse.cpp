/**
 * @file cse.cpp
 * Common-subexpression elimination for generated kernels (see cse.hpp for the design), the
 * pipeline: GiNaC expressions -> hash-consed n-ary DAG (cse_convert.cpp, cse_nary_dag.cpp) ->
 * greedy factoring of shared sub-sums and sub-products (cse_factor.cpp) -> binary DAG, hash-consed
 * again (cse_binary.cpp) -> straight-line C with temporaries (cse_print.cpp).
 */
#include "pardel_codegen/cse.hpp"

#include "cse_binary.hpp"

namespace pardel_codegen {

KernelCode generate_kernel_code(const std::vector<KernelOutput>& outputs, const std::vector<KernelInput>& inputs,
                                const CseOptions& options, KernelCode* extended) {
  using namespace cse;
  NDag ndag;
  std::vector<Scaled> roots;
  {
    struct DigitsGuard {
      long saved = GiNaC::Digits;
      DigitsGuard() { GiNaC::Digits = 30; }
      ~DigitsGuard() { GiNaC::Digits = saved; }
    } digits;
    Converter converter(ndag, inputs);
    for (const KernelOutput& out : outputs) {
      Exact x = converter.convert(out.value);
      roots.push_back({num_of(x.coef), x.node});
    }
  }
  rebuild(ndag, roots);
  long long before = 0;
  {
    BDag naive;
    Lowerer lower(ndag, naive);
    std::vector<int> broots;
    for (const Scaled& s : roots) broots.push_back(lower.lower_output(s));
    before = tree_ops(naive, broots);
  }
  rebuild(ndag, roots);
  if (options.factor_sums) factor_pairs(ndag, roots, false, options.max_factoring_rounds);
  if (options.factor_products) factor_pairs(ndag, roots, true, options.max_factoring_rounds);
  if (options.factor_sums) factor_pairs(ndag, roots, false, options.max_factoring_rounds);
  rebuild(ndag, roots);
  BDag bdag;
  Lowerer lower(ndag, bdag);
  std::vector<int> broots;
  std::vector<std::string> targets;
  for (std::size_t i = 0; i < roots.size(); ++i) {
    broots.push_back(lower.lower_output(roots[i]));
    targets.push_back(outputs[i].target);
  }
  share_reciprocals(bdag, broots);
  Printer printer(bdag, options.temp_prefix);
  KernelCode code = printer.emit(targets, broots);
  code.ops_before = before;
  if (extended) {
    Printer wide(bdag, options.temp_prefix, true);
    *extended = wide.emit(targets, broots);
    extended->ops_before = before;
  }
  return code;
}

}  // namespace pardel_codegen
