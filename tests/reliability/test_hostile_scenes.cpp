// Scene values at the edges, given to the built `pardel solve`: grid.N at and beyond the limits of
// int and int64, inf and nan for T, t0, boundary values and knots (in the file and through --set),
// knots at, before and beyond the ends and two on one node, duplicate keys and tables, threads
// negative or huge, damping at 1 or rounding to 1, values of the wrong type, a byte-order mark and
// CRLF line ends, a directory in place of the scene. Each refused scene must exit with status 2
// and a message naming FILE:LINE:COL (or the --set) and the key, and create no output folder; no
// case may crash or hang.
#include <gtest/gtest.h>

#include <ostream>
#include <string>
#include <vector>

#include "pardel_process.hpp"

namespace {

using namespace reliability;

/** A scene: root keys, then the tables; `grid`, `boundary` and `extra` are inserted verbatim. */
struct Case {
  const char* name;
  std::string root;      ///< keys before the first table (model is added unless root has one)
  std::string grid;      ///< the [grid] body
  std::string boundary;  ///< the [boundary] body
  std::string extra;     ///< tables after [boundary]
  std::vector<std::string> args;  ///< more arguments of pardel solve (--set ...)
  std::string expected;  ///< substring of the message; "FILE" stands for the scene's path
};

const char* kGrid = "T = 30\nN = 20\n";
const char* kBoundary = "q0 = [0, 0]\nqN = [6, 5]\n";

void PrintTo(const Case& c, std::ostream* os) { *os << c.name; }

std::string scene_text(const Case& c) {
  std::string text = c.root.find("model") == std::string::npos ? "model = \"fuel_nav\"\n" + c.root : c.root;
  text += "[grid]\n" + c.grid + "[boundary]\n" + c.boundary + c.extra;
  return text;
}

class HostileScene : public ::testing::TestWithParam<Case> {
 protected:
  void SetUp() override { dir_ = scratch_folder("pardel_hostile_scene"); }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_P(HostileScene, IsRefusedWithItsLocation) {
  const Case& c = GetParam();
  const fs::path scene = dir_ / "s.toml";
  write_text(scene, scene_text(c));
  std::vector<std::string> args = {"solve", scene.string(), "--out", (dir_ / "out").string(), "--no-plot", "--quiet"};
  args.insert(args.end(), c.args.begin(), c.args.end());
  const Outcome o = run_pardel(args, dir_ / "log");
  EXPECT_FALSE(o.timed_out);
  EXPECT_EQ(o.status, 2) << o.output;
  std::string expected = c.expected;
  if (expected.rfind("FILE", 0) == 0) expected = scene.string() + expected.substr(4);
  EXPECT_NE(o.output.find(expected), std::string::npos) << "expected: " << expected << "\ngot: " << o.output;
  EXPECT_FALSE(fs::exists(dir_ / "out")) << "a refused scene created its output folder";
}

const char* kKnot15 = "[[knots]]\nt = 15\nq = [1, 1]\n";

INSTANTIATE_TEST_SUITE_P(
    EdgeValues, HostileScene,
    ::testing::Values(
        // grid.N at the limits of int and int64 (the reader allows 2..10^8).
        Case{"N_int_max", "", "T = 30\nN = 2147483647\n", kBoundary, "", {},
             "FILE:4:5: error: grid.N must be between 2 and 100000000, got 2147483647"},
        Case{"N_beyond_int", "", "T = 30\nN = 2147483648\n", kBoundary, "", {},
             "FILE:4:5: error: grid.N must be between 2 and 100000000, got 2147483648"},
        Case{"N_int64_max", "", "T = 30\nN = 9223372036854775807\n", kBoundary, "", {},
             "got 9223372036854775807"},
        Case{"N_beyond_int64", "", "T = 30\nN = 9223372036854775808\n", kBoundary, "", {},
             "'9223372036854775808' is not representable in 64 bits"},
        Case{"N_int64_min", "", "T = 30\nN = -9223372036854775808\n", kBoundary, "", {},
             "FILE:4:5: error: grid.N must be between 2 and 100000000, got -9223372036854775808"},
        Case{"set_N_beyond_int", "", kGrid, kBoundary, "", {"--set", "grid.N=2147483648"},
             "--set grid.N=2147483648: error: grid.N must be between 2 and 100000000, got 2147483648"},
        // inf and nan.
        Case{"T_inf", "", "T = inf\nN = 20\n", kBoundary, "", {}, "FILE:3:5: error: grid.T must be a finite number, got inf"},
        Case{"T_nan", "", "T = nan\nN = 20\n", kBoundary, "", {}, "FILE:3:5: error: grid.T must be a finite number, got nan"},
        Case{"T_minus_inf", "", "T = -inf\nN = 20\n", kBoundary, "", {}, "grid.T must be a finite number, got -inf"},
        Case{"t0_nan", "", "t0 = nan\nT = 30\nN = 20\n", kBoundary, "", {},
             "FILE:3:6: error: grid.t0 must be a finite number, got nan"},
        Case{"set_T_inf", "", kGrid, kBoundary, "", {"--set", "grid.T=inf"},
             "--set grid.T=inf: error: grid.T must be a finite number, got inf"},
        Case{"q0_nan", "", kGrid, "q0 = [nan, 0]\nqN = [6, 5]\n", "", {},
             "FILE:6:7: error: boundary.q0[0] must be a finite number, got nan"},
        Case{"qN_inf", "", kGrid, "q0 = [0, 0]\nqN = [6, inf]\n", "", {},
             "FILE:7:10: error: boundary.qN[1] must be a finite number, got inf"},
        Case{"set_q0_nan", "", kGrid, kBoundary, "", {"--set", "boundary.q0=[nan,0]"},
             "--set boundary.q0=[nan,0]: error: boundary.q0[0] must be a finite number, got nan"},
        Case{"set_knot_q_nan", "", kGrid, kBoundary, "", {"--set", "knots=[{t=15,q=[1,nan]}]"},
             "--set knots=[{t=15,q=[1,nan]}]: error: knots[0].q[1] must be a finite number, got nan"},
        Case{"knot_t_nan", "", kGrid, kBoundary, "[[knots]]\nt = nan\nq = [1, 1]\n", {},
             "FILE:9:5: error: knots[0].t must be a finite number, got nan"},
        Case{"knot_q_inf", "", kGrid, kBoundary, "[[knots]]\nt = 15\nq = [-inf, 1]\n", {},
             "knots[0].q[0] must be a finite number, got -inf"},
        // Knots at and beyond the ends, and two on one node.
        Case{"knot_at_t0", "", kGrid, kBoundary, "[[knots]]\nt = 0\nq = [1, 1]\n", {},
             "FILE:9:5: error: knots[0].t = 0 must lie strictly inside the grid (0, 30)"},
        Case{"knot_beyond_end", "", kGrid, kBoundary, "[[knots]]\nt = 45\nq = [1, 1]\n", {},
             "knots[0].t = 45 must lie strictly inside the grid (0, 30)"},
        Case{"knot_far_before_start", "", kGrid, kBoundary, "[[knots]]\nt = -1e308\nq = [1, 1]\n", {},
             "knots[0].t = -1e+308 must lie strictly inside the grid"},
        Case{"knot_far_beyond_end", "", kGrid, kBoundary, "[[knots]]\nt = 1.7e308\nq = [1, 1]\n", {},
             "knots[0].t = 1.7e+308 must lie strictly inside the grid"},
        Case{"two_knots_same_time", "", kGrid, kBoundary, std::string(kKnot15) + "[[knots]]\nt = 1.5e1\nq = [2, 2]\n",
             {}, "FILE:12:5: error: knots[1].t = 15: another knot is already at node k = 10"},
        Case{"two_knots_same_node_within_rounding", "", kGrid, kBoundary,
             std::string(kKnot15) + "[[knots]]\nt = 15.0000000001\nq = [2, 2]\n", {},
             "another knot is already at node k = 10"},
        // Duplicate keys and tables (TOML forbids both).
        Case{"duplicate_key", "", "T = 30\nN = 20\nN = 30\n", kBoundary, "", {},
             "FILE:5:5: error: Error while parsing key-value pair: cannot redefine existing integer 'N'"},
        Case{"duplicate_table", "", kGrid, kBoundary, "[grid]\nT = 3\n", {},
             "FILE:8:1: error: Error while parsing table header: cannot redefine existing table 'grid'"},
        Case{"duplicate_model_key", "model = \"fuel_nav\"\nmodel = \"harmonic\"\n", kGrid, kBoundary, "", {},
             "FILE:2:"},
        Case{"knots_array_then_table_array", "knots = []\n", kGrid, kBoundary, kKnot15, {}, "FILE:9:"},
        // Threads.
        Case{"threads_int64_max", "", kGrid, kBoundary, "[solver]\nthreads = 9223372036854775807\n", {},
             "FILE:9:11: error: solver.threads must be between 0 (all cores) and 4096, got 9223372036854775807"},
        Case{"set_threads_4097", "", kGrid, kBoundary, "", {"--set", "solver.threads=4097"},
             "--set solver.threads=4097: error: solver.threads must be between 0 (all cores) and 4096, got 4097"},
        Case{"set_threads_minus_one", "", kGrid, kBoundary, "", {"--set", "solver.threads=-1"},
             "--set solver.threads=-1: error: solver.threads must be between 0 (all cores) and 4096, got -1"},
        Case{"threads_float", "", kGrid, kBoundary, "[solver]\nthreads = 1e3\n", {},
             "solver.threads must be an integer, got a floating-point number"},
        Case{"option_threads_minus_one", "", kGrid, kBoundary, "", {"--threads", "-1"},
             "--threads -1: error: --threads must be between 0 (all cores) and 4096, got -1"},
        Case{"option_threads_huge", "", kGrid, kBoundary, "", {"--threads", "99999999999999999999"}, "--threads"},
        // Damping and tolerances at their edges.
        Case{"damping_one", "", kGrid, kBoundary, "[solver]\ndamping = 1.0\n", {},
             "FILE:9:11: error: solver.damping must be in [0, 1), got 1"},
        Case{"damping_rounds_to_one", "", kGrid, kBoundary, "", {"--set", "solver.damping=0.99999999999999999"},
             "--set solver.damping=0.99999999999999999: error: solver.damping must be in [0, 1), got 1"},
        Case{"damping_nan", "", kGrid, kBoundary, "[solver]\ndamping = nan\n", {},
             "solver.damping must be a finite number, got nan"},
        Case{"damping_negative_zero_below", "", kGrid, kBoundary, "[solver]\ndamping = -1e-300\n", {},
             "solver.damping must be in [0, 1), got -1e-300"},
        Case{"tol_nan", "", kGrid, kBoundary, "[solver]\ntol = nan\n", {}, "solver.tol must be a finite number, got nan"},
        Case{"rtol_one", "", kGrid, kBoundary, "[solver]\nrtol = 1\n", {}, "solver.rtol must be in (0, 1), got 1"},
        Case{"max_iterations_negative", "", kGrid, kBoundary, "[solver]\nmax_iterations = -1\n", {},
             "solver.max_iterations must be >= 0 (0: evaluate the start only), got -1"},
        Case{"refine_factor_inf", "", kGrid, kBoundary, "[solver]\nrefine = {start_N = 2, factor = inf}\n", {},
             "solver.refine.factor must be a finite number, got inf"},
        Case{"refine_settle_one", "", kGrid, kBoundary, "[solver]\nrefine = {start_N = 2, settle = 1}\n", {},
             "solver.refine.settle must be in (0, 1), got 1"},
        Case{"set_history_every_zero", "", kGrid, kBoundary, "", {"--set", "solver.history_every=0"},
             "--set solver.history_every=0: error: solver.history_every must be >= 1, got 0"},
        Case{"divergence_factor_one", "", kGrid, kBoundary, "[solver]\ndivergence_factor = 1\n", {},
             "FILE:9:21: error: solver.divergence_factor must be > 1, got 1"},
        // Wrong types.
        Case{"model_is_an_integer", "model = 42\n", kGrid, kBoundary, "", {},
             "FILE:1:9: error: model must be a string, got an integer 42"},
        Case{"N_is_a_boolean", "", "T = 30\nN = true\n", kBoundary, "", {},
             "grid.N must be an integer, got a boolean true"},
        Case{"boundary_is_an_array", "boundary = [1, 2]\n", kGrid, kBoundary, "", {}, "FILE:"},
        Case{"knots_is_a_string", "knots = \"x\"\n", kGrid, kBoundary, "", {},
             "FILE:2:9: error: knots must be an array of tables ([[knots]] with t and q), got a string"},
        Case{"method_is_an_array", "", kGrid, kBoundary, "[solver]\nmethod = [\"newton\"]\n", {},
             "FILE:9:10: error: solver.method must be a string, got an array"},
        Case{"set_grid_to_a_number", "", kGrid, kBoundary, "", {"--set", "grid=5"},
             "--set grid=5: error: grid must be a table, got an integer"},
        Case{"output_dir_empty", "", kGrid, kBoundary, "[output]\ndir = \"\"\n", {},
             "output.dir must not be empty"},
        // A byte-order mark is skipped: an error after it is placed from the text.
        Case{"error_after_byte_order_mark", "\xef\xbb\xbfmodel = 42\n", kGrid, kBoundary, "", {},
             "FILE:1:9: error: model must be a string, got an integer 42"}),
    [](const ::testing::TestParamInfo<Case>& info) { return std::string(info.param.name); });

class SceneFile : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = scratch_folder("pardel_scene_file"); }
  void TearDown() override { fs::remove_all(dir_); }
  Outcome solve(const fs::path& scene) {
    return run_pardel({"solve", scene.string(), "--out", (dir_ / "out").string(), "--no-plot", "--quiet"},
                      dir_ / "log");
  }
  fs::path dir_;
};

const std::string kGood = "model = \"fuel_nav\"\n[grid]\nT = 30\nN = 20\n[boundary]\nq0 = [0, 0]\nqN = [6, 5]\n";

TEST_F(SceneFile, ByteOrderMarkIsSkipped) {
  write_text(dir_ / "bom.toml", "\xef\xbb\xbf" + kGood);
  const Outcome o = solve(dir_ / "bom.toml");
  EXPECT_EQ(o.status, 0) << o.output;
  EXPECT_TRUE(fs::exists(dir_ / "out" / "summary.json"));
}

TEST_F(SceneFile, CrlfLineEndsAreRead) {
  std::string text;
  for (char c : kGood + "[solver]\nmethod = \"newton\" # comment\n") text += c == '\n' ? std::string("\r\n") : std::string(1, c);
  write_text(dir_ / "crlf.toml", text);
  const Outcome o = solve(dir_ / "crlf.toml");
  EXPECT_EQ(o.status, 0) << o.output;
  EXPECT_NE(read_text(dir_ / "out" / "summary.json").find("\"method\": \"newton\""), std::string::npos);
}

TEST_F(SceneFile, DirectoryInPlaceOfTheScene) {
  fs::create_directories(dir_ / "folder.toml");
  const Outcome o = solve(dir_ / "folder.toml");
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find((dir_ / "folder.toml").string() + ": error: is a directory, not a scene file"),
            std::string::npos)
      << o.output;
  EXPECT_FALSE(fs::exists(dir_ / "out"));
}

TEST_F(SceneFile, MissingScene) {
  const Outcome o = solve(dir_ / "nothing.toml");
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find("nothing.toml: error: cannot open scene file"), std::string::npos) << o.output;
}

TEST_F(SceneFile, NulBytesInAString) {
  write_text(dir_ / "nul.toml", std::string("model = \"fuel\0nav\"\n", 19) + kGood.substr(kGood.find('[')));
  const Outcome o = solve(dir_ / "nul.toml");
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find((dir_ / "nul.toml").string() + ":1:"), std::string::npos) << o.output;
}

}  // namespace
