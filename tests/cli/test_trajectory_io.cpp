// Tests of trajectory.csv writing and reading and of atomic writes (pardel/app/trajectory_io.hpp).
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "pardel/app/trajectory_io.hpp"

namespace {

using namespace pardel;
using namespace pardel::app;
namespace fs = std::filesystem;

class TrajectoryFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("pardel_test_io_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  std::string write(const std::string& name, const std::string& text) const {
    std::ofstream(path(name)) << text;
    return path(name);
  }
  fs::path dir_;
};

Trajectory sample(const pardel_model& model, int N) {
  Trajectory t;
  t.N = N;
  t.dim = model.dim;
  for (int k = 0; k <= N; ++k) {
    t.t.push_back(0.1 * k + 1.0 / 3.0);
    for (int j = 0; j < model.dim; ++j) t.q.push_back(std::sin(0.3 * k + j) / 7.0);
  }
  return t;
}

TEST_F(TrajectoryFiles, HeaderNamesCoordinatesAndDerivatives) {
  const pardel_model* order2 = find_model("interp_fuel");
  ASSERT_NE(order2, nullptr);
  EXPECT_EQ(state_column_names(*order2), (std::vector<std::string>{"x", "y", "x'", "y'"}));
  const std::string csv = trajectory_csv(*order2, sample(*order2, 3));
  EXPECT_EQ(csv.substr(0, csv.find('\n')), "k,t,x,y,x',y'");
  const pardel_model* order1 = find_model("fuel_nav");
  ASSERT_NE(order1, nullptr);
  const std::string csv1 = trajectory_csv(*order1, sample(*order1, 3));
  EXPECT_EQ(csv1.substr(0, csv1.find('\n')), "k,t,x,y,x',y'");  // velocities: node_velocity
}

TEST(NodeVelocity, ExactForAQuadraticPathOnAnUnevenGridEndsIncluded) {
  // q(t) = 3 - 2t + 5t^2 on uneven node times: the three-node quadratic is q itself, so every
  // node, the first and the last included, gets q'(t_k) = -2 + 10 t_k.
  Trajectory path;
  path.N = 4;
  path.dim = 1;
  path.t = {0.0, 0.3, 0.45, 1.0, 1.7};
  for (double t : path.t) path.q.push_back(3 - 2 * t + 5 * t * t);
  for (int k = 0; k <= path.N; ++k) EXPECT_NEAR(node_velocity(path, k, 0), -2 + 10 * path.t[k], 1e-12) << k;
}

TEST(NodeVelocity, SecondOrderAtTheEndPointsAsInside) {
  // q = sin t on a uniform grid: the error at the end points falls by 4 when h halves, as inside.
  auto max_error = [](int N, bool ends) {
    Trajectory path;
    path.N = N;
    path.dim = 1;
    for (int k = 0; k <= N; ++k) {
      path.t.push_back(1.5 * k / N);
      path.q.push_back(std::sin(path.t.back()));
    }
    double worst = 0;
    for (int k = 0; k <= N; ++k) {
      if ((k == 0 || k == N) != ends) continue;
      worst = std::max(worst, std::fabs(node_velocity(path, k, 0) - std::cos(path.t[k])));
    }
    return worst;
  };
  for (bool ends : {true, false}) {
    const double ratio = max_error(40, ends) / max_error(80, ends);
    EXPECT_GT(ratio, 3.8) << (ends ? "end points" : "interior");
    EXPECT_LT(ratio, 4.2) << (ends ? "end points" : "interior");
  }
}

TEST(NodeVelocity, OneIntervalGivesItsSlopeAndCoincidentTimesNaN) {
  Trajectory path;
  path.N = 1;
  path.dim = 1;
  path.t = {0, 2};
  path.q = {1, 5};
  EXPECT_EQ(node_velocity(path, 0, 0), 2);
  EXPECT_EQ(node_velocity(path, 1, 0), 2);
  path.N = 2;
  path.t = {0, 0, 1};
  path.q = {1, 1, 2};
  EXPECT_TRUE(std::isnan(node_velocity(path, 1, 0)));
}

TEST_F(TrajectoryFiles, RoundTripIsExact) {
  for (const char* name : {"fuel_nav", "interp_fuel"}) {
    const pardel_model* model = find_model(name);
    ASSERT_NE(model, nullptr);
    const Trajectory original = sample(*model, 17);
    write_file_atomic(path("t.csv"), trajectory_csv(*model, original));
    const Trajectory back = read_trajectory_csv(path("t.csv"), *model);
    EXPECT_EQ(back.N, original.N);
    EXPECT_EQ(back.dim, original.dim);
    EXPECT_EQ(back.t, original.t);  // 17 significant digits round-trip doubles exactly
    EXPECT_EQ(back.q, original.q);
  }
}

TEST_F(TrajectoryFiles, OrderOneVelocitiesAreFiniteDifferences) {
  const pardel_model* model = find_model("fuel_nav");
  ASSERT_NE(model, nullptr);
  Trajectory line;
  line.N = 4;
  line.dim = 2;
  for (int k = 0; k <= 4; ++k) {
    line.t.push_back(0.5 * k);
    line.q.push_back(3.0 * 0.5 * k);
    line.q.push_back(-1.0 * 0.5 * k);
  }
  std::istringstream csv(trajectory_csv(*model, line));
  std::string row;
  std::getline(csv, row);
  while (std::getline(csv, row)) {
    std::istringstream cells(row);
    std::string cell;
    std::vector<double> values;
    while (std::getline(cells, cell, ',')) values.push_back(std::stod(cell));
    ASSERT_EQ(values.size(), 6u);
    EXPECT_DOUBLE_EQ(values[4], 3.0);
    EXPECT_DOUBLE_EQ(values[5], -1.0);
  }
}

TEST_F(TrajectoryFiles, ErrorsNameFileLineAndColumn) {
  const pardel_model& model = *find_model("fuel_nav");
  auto error = [&](const std::string& text) {
    const std::string p = write("bad.csv", text);
    try {
      read_trajectory_csv(p, model);
    } catch (const std::runtime_error& e) {
      return std::string(e.what()).substr(p.size());
    }
    return std::string("(no error)");
  };
  EXPECT_EQ(error("k,t,x\n0,0,0\n"), ":1:1: error: missing column 'y' of model fuel_nav");
  EXPECT_EQ(error("k,t,x,y\n0,0,0,0\n1,0.5,abc,1\n2,1,1,1\n"), ":3:7: error: column 'x': 'abc' is not a number");
  EXPECT_EQ(error("k,t,x,y\n0,0,0,0\n2,0.5,1,1\n"), ":3:1: error: k = 2 out of sequence; expected 1");
  EXPECT_EQ(error("k,t,x,y\n0,0,0,0\n1,0.5,1\n"), ":3:1: error: 3 cells, expected 4 as in the header");
  EXPECT_EQ(error("k,t,x,y\n0,0,0,0\n1,1,1,1\n"), ":3:1: error: 2 nodes; a trajectory needs at least 3 (N >= 2)");
  EXPECT_EQ(error("k,t,x,y\n0,0,0,0\n1,0.5,nan,1\n2,1,1,1\n"), ":3:7: error: column 'x': value nan is not finite");
  // Out of range as strtod reads it (ERANGE): a subnormal value, an underflow to 0, an overflow.
  EXPECT_EQ(error("k,t,x,y\n0,0,0,0\n1,0.5,1e-310,1\n2,1,1,1\n"), ":3:7: error: column 'x': '1e-310' is not a number");
  EXPECT_EQ(error("k,t,x,y\n0,0,0,0\n1,0.5,1,1e-400\n2,1,1,1\n"), ":3:9: error: column 'y': '1e-400' is not a number");
  EXPECT_EQ(error("k,t,x,y\n0,0,0,0\n1,0.5,1e400,1\n2,1,1,1\n"), ":3:7: error: column 'x': '1e400' is not a number");
  EXPECT_EQ(error("k,t,x,y\n0,0,0,0\n1,0.5,1.5e,1\n2,1,1,1\n"), ":3:7: error: column 'x': '1.5e' is not a number");
  EXPECT_EQ(error("k,t,x,y\n0,0,0,0\n1,0.5,1 2,1\n2,1,1,1\n"), ":3:7: error: column 'x': '1 2' is not a number");
}

TEST_F(TrajectoryFiles, NumbersAreReadAsStrtodReadsThem) {
  // Forms std::from_chars does not take and strtod does (a leading '+', a tab, hexadecimal), the
  // smallest normal number, a negative zero, spaces and a carriage return around the cells.
  const pardel_model& model = *find_model("fuel_nav");
  const std::string p = write("forms.csv",
                              "k , t,x,y\r\n"
                              "0,0, +1.5 ,\t2\r\n"
                              "1,0.5,0x1p-3,2.2250738585072014e-308\n"
                              "+2, 1 ,-0,1E+2\n");
  const Trajectory read = read_trajectory_csv(p, model);
  ASSERT_EQ(read.N, 2);
  EXPECT_EQ(read.t, (std::vector<double>{0, 0.5, 1}));
  EXPECT_EQ(read.q, (std::vector<double>{1.5, 2, 0.125, 2.2250738585072014e-308, 0, 100}));
  EXPECT_TRUE(std::signbit(read.q[4]));
}

TEST_F(TrajectoryFiles, AtomicWriteReplacesAndLeavesNoTemporary) {
  write_file_atomic(path("a.txt"), "first");
  write_file_atomic(path("a.txt"), "second");
  std::ifstream in(path("a.txt"));
  std::string content((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(content, "second");
  int files = 0;
  for (const auto& entry : fs::directory_iterator(dir_)) {
    (void)entry;
    ++files;
  }
  EXPECT_EQ(files, 1);
  EXPECT_THROW(write_file_atomic(path("missing/dir/a.txt"), "x"), std::runtime_error);
}

TEST(FormatDouble, SeventeenSignificantDigits) {
  // The text of printf's %.17g, on values spread over the whole range of doubles.
  std::uint64_t bits = 0x9E3779B97F4A7C15ull;
  for (int i = 0; i < 20000; ++i) {
    bits ^= bits << 13;
    bits ^= bits >> 7;
    bits ^= bits << 17;
    double value;
    std::memcpy(&value, &bits, sizeof value);
    if (!std::isfinite(value)) continue;
    char expected[40];
    std::snprintf(expected, sizeof expected, "%.17g", value);
    ASSERT_EQ(format_double(value), expected);
  }
  EXPECT_EQ(format_double(0.1), "0.10000000000000001");
  EXPECT_EQ(format_double(1.0 / 3.0), "0.33333333333333331");
  EXPECT_EQ(format_double(std::nan("")), "nan");
  EXPECT_EQ(format_double(-HUGE_VAL), "-inf");
}

}  // namespace
