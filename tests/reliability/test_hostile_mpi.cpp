// `mpirun pardel solve` with hostile input: more ranks than the grid has room for, a scene that
// every rank refuses, and a scene that one rank only refuses. Each must end within the time limit
// with a non-zero exit status and the message (no hang of the ranks, no outputs written). And
// interruptions of `mpirun pardel solve` and `mpirun pardel sweep`: their exit status and outputs.
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <functional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "pardel_process.hpp"

namespace {

using namespace reliability;

const std::vector<std::string> kMpiEnv = {"OMPI_ALLOW_RUN_AS_ROOT=1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1",
                                          "OMP_NUM_THREADS=1", "OMP_WAIT_POLICY=PASSIVE"};

class HostileMpi : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = scratch_folder("pardel_hostile_mpi"); }
  void TearDown() override { fs::remove_all(dir_); }
  Outcome mpirun(int ranks, const fs::path& scene) {
    return finish_pardel(start_program(PARDEL_MPIEXEC_PATH,
                                       {"-np", std::to_string(ranks), "--oversubscribe", PARDEL_CLI_PATH, "solve",
                                        scene.string(), "--out", (dir_ / "out").string(), "--no-plot", "--quiet"},
                                       dir_ / "log", kMpiEnv),
                         dir_ / "log", 120);
  }
  fs::path dir_;
};

TEST_F(HostileMpi, MoreRanksThanTheGridHasRoomFor) {
  write_text(dir_ / "n2.toml", "model = \"fuel_nav\"\n[grid]\nT = 30\nN = 2\n[boundary]\nq0 = [0, 0]\nqN = [6, 5]\n"
                               "[solver]\nmethod = \"newton\"\n");
  const Outcome o = mpirun(3, dir_ / "n2.toml");
  EXPECT_FALSE(o.timed_out) << o.output;
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find((dir_ / "n2.toml").string() + ": error: grid.N = 2 is too small for 3 ranks"),
            std::string::npos)
      << o.output;
  EXPECT_FALSE(fs::exists(dir_ / "out" / "summary.json")) << "outputs written for a refused solve";
}

TEST_F(HostileMpi, SceneRefusedOnEveryRank) {
  write_text(dir_ / "bad.toml", "model = \"fuel_nav\"\n[grid]\nT = 30\nN = 200\n[boundary]\nq0 = [0, nan]\nqN = [6, 5]\n");
  const Outcome o = mpirun(2, dir_ / "bad.toml");
  EXPECT_FALSE(o.timed_out) << o.output;
  EXPECT_NE(o.status, 0) << o.output;
  EXPECT_NE(o.output.find((dir_ / "bad.toml").string() + ":6:10: error: boundary.q0[1] must be a finite number"),
            std::string::npos)
      << o.output;
  EXPECT_FALSE(fs::exists(dir_ / "out"));
}

TEST_F(HostileMpi, SceneRefusedOnOneRankOnly) {
  write_text(dir_ / "good.toml", "model = \"fuel_nav\"\n[grid]\nT = 30\nN = 200\n[boundary]\nq0 = [0, 0]\nqN = [6, 5]\n"
                                 "[solver]\nmethod = \"newton\"\n");
  write_text(dir_ / "bad.toml", "model = \"fuel_nav\"\n[grid]\nT = 30\nN = 200\n[boundary]\nq0 = [0, nan]\nqN = [6, 5]\n");
  // Rank 1 reads bad.toml, rank 0 good.toml: rank 0 waits for rank 1 in the distributed solve.
  const std::string command = std::string("if [ \"$OMPI_COMM_WORLD_RANK\" = 1 ]; then s=bad; else s=good; fi; exec '") +
                              PARDEL_CLI_PATH + "' solve '" + dir_.string() + "'/$s.toml --out '" +
                              (dir_ / "out").string() + "' --no-plot --quiet";
  const Outcome o = finish_pardel(
      start_program(PARDEL_MPIEXEC_PATH, {"-np", "2", "--oversubscribe", "/bin/sh", "-c", command}, dir_ / "log", kMpiEnv),
      dir_ / "log", 60);
  EXPECT_FALSE(o.timed_out) << "mpirun hangs:\n" << o.output;
  EXPECT_NE(o.status, 0) << o.output;
  EXPECT_NE(o.output.find((dir_ / "bad.toml").string() + ":6:10: error: boundary.q0[1] must be a finite number"),
            std::string::npos)
      << o.output;
  EXPECT_FALSE(fs::exists(dir_ / "out" / "summary.json")) << "outputs written for a refused solve";
}

// Interruption under mpirun. A SIGTERM that reaches the ranks (a batch system signals the job's
// tasks; `kill` of the pardel processes) ends every rank with status 6, and so mpirun. Open MPI's
// mpirun itself, when it receives SIGINT or SIGTERM, passes SIGTERM on to the ranks (which stop
// and write their outputs and checkpoint) but sets its own exit status to 1 whatever the ranks
// return (docs/cluster.md).

/** A slow solve: Jacobi-Newton towards a tolerance it cannot reach. */
fs::path slow_scene(const fs::path& dir) {
  write_text(dir / "slow.toml", "model = \"fuel_nav\"\n[grid]\nT = 30\nN = 1000\n[boundary]\nq0 = [0, 0]\nqN = [6, 5]\n"
                                "[solver]\nmethod = \"jacobi-newton\"\ntol = 1e-15\nmax_iterations = 100000000\n");
  return dir / "slow.toml";
}

/** Starts `mpirun -np 2` of pardel with `args`, each rank recording its process id in DIR/pids. */
pid_t start_ranks(const fs::path& dir, const std::string& args) {
  const std::string command = "echo $$ >> '" + (dir / "pids").string() + "'; exec '" + PARDEL_CLI_PATH + "' " + args;
  return start_program(PARDEL_MPIEXEC_PATH, {"-np", "2", "--oversubscribe", "/bin/sh", "-c", command}, dir / "log",
                       kMpiEnv);
}

/** Waits (at most 60 s) until both ranks have recorded their ids and `ready` holds; then SIGTERM to each. */
bool signal_ranks(const fs::path& dir, const std::function<bool()>& ready) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  std::vector<pid_t> pids;
  while (std::chrono::steady_clock::now() < deadline) {
    pids.clear();
    std::istringstream in(read_text(dir / "pids"));
    for (long pid = 0; in >> pid;) pids.push_back(static_cast<pid_t>(pid));
    if (pids.size() == 2 && ready()) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  if (pids.size() != 2) return false;
  std::this_thread::sleep_for(std::chrono::seconds(1));
  for (const pid_t pid : pids) ::kill(pid, SIGTERM);
  return true;
}

TEST_F(HostileMpi, SigtermToTheRanksOfASolveEndsMpirunWithStatus6) {
  const fs::path out = dir_ / "out";
  const pid_t mpirun = start_ranks(dir_, "solve '" + slow_scene(dir_).string() + "' --out '" + out.string() +
                                             "' --no-plot --quiet --threads 1");
  ASSERT_TRUE(signal_ranks(dir_, [&out] { return fs::exists(out); })) << read_text(dir_ / "log");
  const Outcome o = finish_pardel(mpirun, dir_ / "log", 120);
  ASSERT_FALSE(o.timed_out) << o.output;
  EXPECT_EQ(o.status, 6) << o.output;
  EXPECT_NE(read_text(out / "summary.json").find("\"status\": \"interrupted\""), std::string::npos);
  EXPECT_TRUE(fs::exists(out / "checkpoint.json"));
  EXPECT_NE(o.output.find("checkpoint written; continue with: pardel solve --resume"), std::string::npos) << o.output;
}

TEST_F(HostileMpi, SigtermToTheRanksOfASweepEndsMpirunWithStatus6) {
  // Jacobi-Newton variants of some 30 000 sweeps each: SIGTERM comes long before the end.
  write_text(dir_ / "sweep.toml", std::string("scene = \"") + PARDEL_SOURCE_DIR + "/scenes/zermelo_1.toml\"\n" +
                                      "set = [\"solver.method=jacobi-newton\", \"solver.threads=1\"]\n"
                                      "[random_guesses]\ncount = 10\nspread = 1\n");
  const fs::path out = dir_ / "out";
  const auto started = std::chrono::steady_clock::now();
  const pid_t mpirun =
      start_ranks(dir_, "sweep '" + (dir_ / "sweep.toml").string() + "' --out '" + out.string() + "' --no-plot --quiet");
  ASSERT_TRUE(signal_ranks(dir_, [&started] { return std::chrono::steady_clock::now() - started > std::chrono::seconds(2); }))
      << read_text(dir_ / "log");
  const Outcome o = finish_pardel(mpirun, dir_ / "log", 120);
  ASSERT_FALSE(o.timed_out) << o.output;
  EXPECT_EQ(o.status, 6) << o.output;
  EXPECT_NE(o.output.find("pardel sweep: interrupted"), std::string::npos) << o.output;
  const std::string index = read_text(out / "sweep.json");
  EXPECT_NE(index.find("\"ranks\": 2"), std::string::npos) << index;
  EXPECT_NE(index.find("\"variants\": 10"), std::string::npos) << index;
}

TEST_F(HostileMpi, SigintToMpirunStopsEveryRankWithItsOutputsAndCheckpoint) {
  const fs::path out = dir_ / "out";
  const pid_t mpirun = start_ranks(dir_, "solve '" + slow_scene(dir_).string() + "' --out '" + out.string() +
                                             "' --no-plot --quiet --threads 1");
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (!fs::exists(out) && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  std::this_thread::sleep_for(std::chrono::seconds(1));
  ::kill(mpirun, SIGINT);
  const Outcome o = finish_pardel(mpirun, dir_ / "log", 120);
  ASSERT_FALSE(o.timed_out) << o.output;
  // Open MPI's own status after its abort (1); never success.
  EXPECT_NE(o.status, 0) << o.output;
  EXPECT_NE(read_text(out / "summary.json").find("\"status\": \"interrupted\""), std::string::npos) << o.output;
  EXPECT_TRUE(fs::exists(out / "checkpoint.json")) << o.output;
}

}  // namespace
