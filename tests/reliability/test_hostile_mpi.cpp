// `mpirun pardel solve` with hostile input: more ranks than the grid has room for, a scene that
// every rank refuses, and a scene that one rank only refuses. Each must end within the time limit
// with a non-zero exit status and the message (no hang of the ranks, no outputs written).
#include <gtest/gtest.h>

#include <string>
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

}  // namespace
