/**
 * @file model_workshop.hpp
 * Test helper for untrusted models: writes a .lag file, runs the real tool chain on it as a user
 * would (pardel-gen, render.py, the C++ compiler with -Wall -Wextra -Werror, dlopen) and reports
 * each step's exit status and diagnostics, so that a crash or a hang of a tool is a test failure
 * instead of a crash of the test. Also checks that a diagnostic names FILE:LINE:COL inside the
 * input, and compares a generated order-1 trapezoid kernel with the discrete Lagrangian computed
 * here from a C++ Lagrangian (value) and with finite differences of the action (gradient).
 */
#ifndef PARDEL_TESTS_RELIABILITY_MODEL_WORKSHOP_HPP
#define PARDEL_TESTS_RELIABILITY_MODEL_WORKSHOP_HPP

#include <dlfcn.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include "pardel/kernel_abi.h"

namespace reliability {

/** What the tool chain did with one .lag file. */
struct Generated {
  std::string lag_path;
  int gen_status = -1;      ///< pardel-gen's exit status (124: killed after the time limit)
  std::string gen_stderr;
  int render_status = -1;   ///< -1 when not reached
  int compile_status = -1;  ///< -1 when not reached
  std::string compile_log;  ///< the compiler's output (empty when warning-free)
  std::string model_name;   ///< from the rendered file name
  const pardel_model* model = nullptr;
};

inline std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/** A single-quoted shell word. */
inline std::string shell_word(const std::string& word) {
  std::string out = "'";
  for (char c : word) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

/** Runs a shell command; its exit status, or 128 + the signal that ended the shell. */
inline int run_shell(const std::string& command) {
  const int status = std::system(command.c_str());
  if (status == -1) return -1;
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return WEXITSTATUS(status);
}

/** A scratch folder per test with the tool chain; loaded models stay valid until TearDown. */
class ModelWorkshop : public ::testing::Test {
 protected:
  void SetUp() override {
    char pattern[] = "/tmp/pardel_reliability_XXXXXX";
    ASSERT_NE(::mkdtemp(pattern), nullptr);
    dir_ = pattern;
  }
  void TearDown() override {
    for (void* handle : handles_) ::dlclose(handle);
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }

  /** Writes `text` to DIR/<file_name> (creating its folders) and returns the path. */
  std::string write_lag(const std::string& file_name, const std::string& text) {
    const std::string path = dir_ + "/" + file_name;
    std::filesystem::create_directories(std::filesystem::path(path).parent_path());
    std::ofstream(path, std::ios::binary) << text;
    return path;
  }

  /**
   * Runs pardel-gen on the file (at most `seconds`), then, if it succeeded, render.py and the
   * compiler (-std=c++17 -Wall -Wextra -Werror) into a shared object, and loads the model.
   */
  Generated generate(const std::string& file_name, const std::string& text, int seconds = 60) {
    Generated g;
    g.lag_path = write_lag(file_name, text);
    const std::string work = dir_ + "/out_" + std::to_string(counter_++);
    std::filesystem::create_directories(work);
    const std::string ir = work + "/model.ir.json";
    g.gen_status = run_shell("timeout -s KILL " + std::to_string(seconds) + " " + shell_word(PARDEL_GEN_PATH) + " " +
                             shell_word(g.lag_path) + " -o " + shell_word(ir) + " --source-name " + shell_word(g.lag_path) +
                             " > /dev/null 2> " + shell_word(work + "/gen.err"));
    if (g.gen_status == 137) g.gen_status = 124;
    g.gen_stderr = read_text(work + "/gen.err");
    if (g.gen_status != 0) return g;
    g.render_status = run_shell(shell_word(PARDEL_PYTHON_PATH) + " " + shell_word(PARDEL_RENDER_SCRIPT_PATH) + " " +
                                shell_word(ir) + " --out-dir " + shell_word(work) + " > " + shell_word(work + "/render.log") +
                                " 2>&1");
    if (g.render_status != 0) {
      g.compile_log = read_text(work + "/render.log");
      return g;
    }
    for (const auto& entry : std::filesystem::directory_iterator(work)) {
      if (entry.path().extension() == ".cpp") g.model_name = entry.path().stem().string();
    }
    if (g.model_name.empty()) return g;
    const std::string so = work + "/model.so";
    g.compile_status = run_shell(shell_word(PARDEL_TEST_CXX) + " -std=c++17 -Wall -Wextra -Werror -O1 -fPIC -shared -I" +
                                 shell_word(PARDEL_ABI_INCLUDE) + " " + shell_word(work + "/" + g.model_name + ".cpp") +
                                 " -o " + shell_word(so) + " " + PARDEL_TEST_LINK + " > " +
                                 shell_word(work + "/compile.log") + " 2>&1");
    g.compile_log = read_text(work + "/compile.log");
    if (g.compile_status != 0) return g;
    void* handle = ::dlopen(so.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!handle) {
      g.compile_log += std::string("dlopen: ") + ::dlerror();
      return g;
    }
    handles_.push_back(handle);
    g.model = static_cast<const pardel_model*>(::dlsym(handle, (g.model_name + "_model").c_str()));
    return g;
  }

  std::string dir_;

 private:
  std::vector<void*> handles_;
  int counter_ = 0;
};

/** The lengths of the lines of `text` as the .lag reader counts them. */
inline std::vector<std::size_t> line_lengths(const std::string& text) {
  std::vector<std::size_t> lengths;
  std::size_t start = 0;
  for (;;) {
    const std::size_t nl = text.find('\n', start);
    const std::size_t end = nl == std::string::npos ? text.size() : nl;
    std::size_t length = end - start;
    if (length > 0 && text[end - 1] == '\r') --length;
    lengths.push_back(length);
    if (nl == std::string::npos) break;
    start = nl + 1;
  }
  if (lengths.size() > 1 && lengths.back() == 0 && !text.empty() && text.back() == '\n') lengths.pop_back();
  return lengths;
}

/** pardel-gen refused the file with exit status 1 and "FILE:LINE:COL: error:" inside the input;
 *  returns "LINE:COL" (empty after a failed expectation). */
inline std::string expect_located_rejection(const Generated& g, const std::string& text) {
  EXPECT_EQ(g.gen_status, 1) << "pardel-gen should refuse the file with exit status 1 (124: time limit, "
                                "128+n: signal n)\n"
                             << g.gen_stderr.substr(0, 2000);
  if (g.gen_status != 1) return "";
  const std::string head = g.lag_path + ":";
  EXPECT_EQ(g.gen_stderr.rfind(head, 0), 0u) << g.gen_stderr.substr(0, 2000);
  if (g.gen_stderr.rfind(head, 0) != 0) return "";
  unsigned long line = 0, column = 0;
  int consumed = 0;
  const int fields = std::sscanf(g.gen_stderr.c_str() + head.size(), "%lu:%lu: error: %n", &line, &column, &consumed);
  EXPECT_TRUE(fields == 2 && consumed > 0) << "no LINE:COL after the file name:\n" << g.gen_stderr.substr(0, 2000);
  if (fields != 2 || consumed == 0) return "";
  const std::vector<std::size_t> lengths = line_lengths(text);
  EXPECT_GE(line, 1u);
  EXPECT_LE(line, lengths.size());
  if (line < 1 || line > lengths.size()) return "";
  EXPECT_GE(column, 1u);
  EXPECT_LE(column, lengths[line - 1] + 1);
  return std::to_string(line) + ":" + std::to_string(column);
}

/** pardel-gen, render.py and the compiler all succeeded without a warning, and the model loaded. */
inline void expect_compiled(const Generated& g) {
  ASSERT_EQ(g.gen_status, 0) << g.gen_stderr.substr(0, 2000);
  ASSERT_EQ(g.render_status, 0) << g.compile_log.substr(0, 2000);
  ASSERT_EQ(g.compile_status, 0) << g.compile_log.substr(0, 4000);
  EXPECT_EQ(g.compile_log, "") << "the compiler printed something";
  ASSERT_NE(g.model, nullptr) << g.compile_log;
  EXPECT_EQ(g.model->abi_version, PARDEL_KERNEL_ABI_VERSION);
}

/** L(t, q, v, p) of an order-1 model. */
using Lagrangian = std::function<double(double t, const double* q, const double* v, const double* p)>;

/**
 * The model's "trapezoid" kernels at a fixed interval agree with h/2 [L(t0,q0,v) + L(t1,q1,v)],
 * v = (q1 - q0)/h (relative 1e-12), and D1, D2 with central differences of the action (1e-6).
 */
inline void expect_trapezoid_matches(const pardel_model& model, const Lagrangian& L, std::vector<double> q0,
                                     std::vector<double> q1) {
  ASSERT_EQ(model.order, 1);
  const int m = model.dim;
  ASSERT_EQ(static_cast<int>(q0.size()), m);
  ASSERT_EQ(static_cast<int>(q1.size()), m);
  const pardel_discretization* disc = nullptr;
  for (int i = 0; i < model.ndiscretizations; ++i) {
    if (std::string(model.discretizations[i].name) == "trapezoid") disc = &model.discretizations[i];
  }
  ASSERT_NE(disc, nullptr) << "model " << model.name << " has no trapezoid discretization";
  const std::vector<double> p(model.param_defaults, model.param_defaults + model.nparams);
  const double h = 0.125, t0 = 0.25, t1 = t0 + h;
  std::vector<double> v(static_cast<std::size_t>(m));
  for (int i = 0; i < m; ++i) v[i] = (q1[i] - q0[i]) / h;
  const double expected = h / 2 * (L(t0, q0.data(), v.data(), p.data()) + L(t1, q1.data(), v.data(), p.data()));
  const double action = disc->action(h, t0, t1, q0.data(), q1.data(), p.data());
  EXPECT_NEAR(action, expected, 1e-12 * std::max(1.0, std::abs(expected))) << "model " << model.name;

  double Ld = 0;
  std::vector<double> D1(static_cast<std::size_t>(m)), D2(static_cast<std::size_t>(m));
  disc->grad(h, t0, t1, q0.data(), q1.data(), p.data(), &Ld, D1.data(), D2.data());
  EXPECT_NEAR(Ld, action, 1e-13 * std::max(1.0, std::abs(action)));
  const double step = 1e-6;
  for (int i = 0; i < m; ++i) {
    for (int side = 0; side < 2; ++side) {
      std::vector<double>& q = side == 0 ? q0 : q1;
      const double keep = q[i];
      q[i] = keep + step;
      const double up = disc->action(h, t0, t1, q0.data(), q1.data(), p.data());
      q[i] = keep - step;
      const double down = disc->action(h, t0, t1, q0.data(), q1.data(), p.data());
      q[i] = keep;
      const double fd = (up - down) / (2 * step);
      const double analytic = side == 0 ? D1[i] : D2[i];
      EXPECT_NEAR(analytic, fd, 1e-6 * std::max(1.0, std::abs(fd)))
          << "model " << model.name << ": D" << side + 1 << "[" << i << "]";
    }
  }
}

}  // namespace reliability

#endif  // PARDEL_TESTS_RELIABILITY_MODEL_WORKSHOP_HPP
