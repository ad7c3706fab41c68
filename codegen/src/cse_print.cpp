/**
 * @file cse_print.cpp
 * The printer of the CSE: counts the uses of every node of the binary DAG, schedules the
 * temporaries (nodes used twice and function calls, named pd_tNNNN in evaluation order) and prints
 * C text, in double or in extended precision.
 */
#include <cstdio>

#include "cse_binary.hpp"

namespace pardel_codegen::cse {

KernelCode Printer::emit(const std::vector<std::string>& targets, const std::vector<int>& roots) {
  KernelCode code;
  uses_.assign(dag_.nodes.size(), 0);
  std::vector<char> seen(dag_.nodes.size(), 0);
  std::vector<int> stack;
  for (int r : roots) {
    ++uses_[static_cast<std::size_t>(r)];
    stack.push_back(r);
  }
  while (!stack.empty()) {
    int id = stack.back();
    stack.pop_back();
    if (seen[static_cast<std::size_t>(id)]) continue;
    seen[static_cast<std::size_t>(id)] = 1;
    const BNode& n = dag_.nodes[static_cast<std::size_t>(id)];
    if (!dag_.leaf(id)) ++code.ops_after;
    if (n.op == BOp::input) code.used_groups.insert(n.group);
    for (int k : n.kids) {
      ++uses_[static_cast<std::size_t>(k)];
      stack.push_back(k);
    }
  }
  emitted_.assign(dag_.nodes.size(), 0);
  for (std::size_t i = 0; i < roots.size(); ++i) {
    schedule(roots[i], code);
    code.outputs.push_back({targets[i], print(roots[i]).first});
  }
  return code;
}

void Printer::schedule(int id, KernelCode& code) {
  if (emitted_[static_cast<std::size_t>(id)]) return;
  emitted_[static_cast<std::size_t>(id)] = 1;
  for (int k : dag_.nodes[static_cast<std::size_t>(id)].kids) schedule(k, code);
  if (temporary(id)) {
    std::string expr = print(id, true).first;
    char buf[32];
    std::snprintf(buf, sizeof buf, "%04d", ++count_);
    name_[static_cast<std::size_t>(id)] = prefix_ + buf;
    code.temporaries.push_back({name_[static_cast<std::size_t>(id)], expr});
  }
}

int Printer::precedence(BOp op) {
  switch (op) {
    case BOp::add:
    case BOp::sub: return 1;
    case BOp::mul:
    case BOp::div: return 2;
    case BOp::neg: return 3;
    default: return 4;
  }
}

std::pair<std::string, int> Printer::print(int id, bool define) {
  const std::string& given = name_[static_cast<std::size_t>(id)];
  if (!define && !given.empty()) return {given, 4};
  const BNode& n = dag_.nodes[static_cast<std::size_t>(id)];
  auto wrap = [](const std::pair<std::string, int>& p, bool paren) { return paren ? "(" + p.first + ")" : p.first; };
  switch (n.op) {
    case BOp::constant: {
      std::string s = extended_ ? c_extended_literal(n.value.q) : c_double_literal(n.value.d);
      return {n.value.d < 0 || s[0] == '(' ? "(" + s + ")" : s, 4};
    }
    case BOp::input: return {n.name, 4};
    case BOp::add:
    case BOp::sub:
    case BOp::mul:
    case BOp::div: {
      const int p = precedence(n.op);
      auto l = print(n.kids[0]);
      auto r = print(n.kids[1]);
      const char* sym = n.op == BOp::add ? " + " : n.op == BOp::sub ? " - " : n.op == BOp::mul ? "*" : "/";
      return {wrap(l, l.second < p) + sym + wrap(r, r.second <= p), p};
    }
    case BOp::neg: {
      auto k = print(n.kids[0]);
      return {"-" + wrap(k, k.second < 4), 3};
    }
    case BOp::call: {
      const FunctionInfo* info = function_info(n.name);
      std::string s = std::string(extended_ ? info->quad_name : info->c_name) + "(";
      for (std::size_t i = 0; i < n.kids.size(); ++i) s += (i ? ", " : "") + print(n.kids[i]).first;
      return {s + ")", 4};
    }
  }
  return {"0.0", 4};
}

}  // namespace pardel_codegen::cse
