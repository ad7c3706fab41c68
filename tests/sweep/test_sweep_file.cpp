// Tests of sweep files (pardel/app/sweep.hpp): what good files produce (configurations,
// guesses, variants) and the messages of bad ones (FILE:LINE:COL, the key, a suggestion).
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "pardel/pardel.hpp"
#include "pardel/app/sweep.hpp"

namespace {

using namespace pardel;
using namespace pardel::app;

// A sweep file placed (by name only) in scenes/sweeps/, so that "../zermelo_1.toml" is the seed's scene.
const std::string kName = std::string(PARDEL_SCENES_DIR) + "/sweeps/test.toml";

const pardel_model* resolve(const std::string& name) { return find_model(name); }

Sweep parse(const std::string& text, const std::vector<std::string>& sets = {}) {
  return parse_sweep(text, kName, sets, resolve);
}

/** The message of the SceneError that parsing `text` raises ("" if none). */
std::string error_of(const std::string& text) {
  try {
    parse(text);
  } catch (const SceneError& error) {
    return error.what();
  }
  return "";
}

TEST(SweepFile, SceneAloneIsOneVariantWithTheScenesGuess) {
  const Sweep sweep = parse("scene = \"../zermelo_1.toml\"\n");
  EXPECT_EQ(sweep.configurations.size(), 1u);
  EXPECT_EQ(sweep.variant_count(), 1);
  const Variant v = make_variant(sweep, 0);
  EXPECT_EQ(v.guess_label, "scene");
  EXPECT_TRUE(v.points.empty());
  EXPECT_EQ(sweep.configurations[0].problem.N, 80);
}

TEST(SweepFile, SetAppliesToEveryConfigurationAndCommandLineComesAfterTheFile) {
  const Sweep sweep = parse("scene = \"../zermelo_1.toml\"\nset = [\"solver.method=newton\", \"grid.N=40\"]\n",
                            {"grid.N=60"});
  EXPECT_EQ(sweep.configurations[0].options.method, Method::newton);
  EXPECT_EQ(sweep.configurations[0].problem.N, 60);
}

TEST(SweepFile, VaryListsAndRangesMakeTheCartesianProductLastAxisFastest) {
  const Sweep sweep = parse(
      "scene = \"../zermelo_1.toml\"\n"
      "[[vary]]\nkey = \"grid.N\"\nvalues = [40, 80]\n"
      "[[vary]]\nkey = \"params.s\"\nfrom = 1.5\nto = 1.7\ncount = 3\n"
      "[[guesses]]\npoints = [[0,0],[3,-1],[6,2]]\n");
  ASSERT_EQ(sweep.configurations.size(), 6u);
  EXPECT_EQ(sweep.variant_count(), 6);
  const int expected_N[] = {40, 40, 40, 80, 80, 80};
  const double expected_s[] = {1.5, 1.6, 1.7, 1.5, 1.6, 1.7};
  for (int c = 0; c < 6; ++c) {
    EXPECT_EQ(sweep.configurations[c].problem.N, expected_N[c]) << c;
    EXPECT_NEAR(sweep.configurations[c].problem.params[0], expected_s[c], 1e-15) << c;
  }
  EXPECT_EQ(sweep.configuration_values[1], (std::vector<std::string>{"40", "1.6"}));
  EXPECT_EQ(sweep.configurations[5].problem.params[0], 1.7);  // the range ends exactly at `to`
}

TEST(SweepFile, ListedGuessesComeBeforeRandomOnesInEachConfiguration) {
  const Sweep sweep = parse(
      "scene = \"../zermelo_1.toml\"\n"
      "[[guesses]]\npoints = [[0,0],[1,3.5],[4,5.5],[6,2]]\n"
      "[random_guesses]\ncount = 3\nseed = 7\nspread = 1.5\n"
      "[[vary]]\nkey = \"params.s\"\nvalues = [1.6, 1.7]\n");
  ASSERT_EQ(sweep.variant_count(), 8);
  EXPECT_EQ(make_variant(sweep, 0).guess_label, "listed 0");
  EXPECT_EQ(make_variant(sweep, 1).guess_label, "random 0");
  EXPECT_EQ(make_variant(sweep, 3).guess_label, "random 2");
  const Variant v = make_variant(sweep, 5);
  EXPECT_EQ(v.configuration, 1);
  EXPECT_EQ(v.guess_label, "random 0");
  EXPECT_EQ(v.points, make_variant(sweep, 1).points);  // the same guesses in every configuration
  EXPECT_EQ(make_variant(sweep, 4).points, sweep.listed_guesses[0]);
}

TEST(SweepFile, RandomGuessesAreReproducibleAndStayInTheirBox) {
  const std::string text =
      "scene = \"../zermelo_1.toml\"\n[random_guesses]\ncount = 20\ninterior_points = 3\nseed = 11\n"
      "box = { min = [-1, -2], max = [8, 7] }\n";
  const Sweep a = parse(text);
  const Sweep b = parse(text);
  const Sweep other = parse(text.substr(0, text.find("seed = 11")) + "seed = 12\n" +
                            text.substr(text.find("box")));
  ASSERT_EQ(a.variant_count(), 20);
  int differing = 0;
  for (int id = 0; id < 20; ++id) {
    const Variant v = make_variant(a, id);
    ASSERT_EQ(v.points.size(), 5u);
    EXPECT_EQ(v.points, make_variant(b, id).points);
    if (v.points != make_variant(other, id).points) ++differing;
    EXPECT_EQ(v.points.front(), (std::vector<double>{0, 0}));
    EXPECT_EQ(v.points.back(), (std::vector<double>{6, 2}));
    for (std::size_t i = 1; i + 1 < v.points.size(); ++i) {
      EXPECT_GE(v.points[i][0], -1);
      EXPECT_LT(v.points[i][0], 8);
      EXPECT_GE(v.points[i][1], -2);
      EXPECT_LT(v.points[i][1], 7);
    }
  }
  EXPECT_EQ(differing, 20);
}

TEST(SweepFile, SpreadPlacesVerticesAroundTheStraightLine) {
  const Sweep sweep =
      parse("scene = \"../zermelo_1.toml\"\n[random_guesses]\ncount = 30\ninterior_points = 1\nspread = 0.5\n");
  double largest = 0;
  for (int id = 0; id < 30; ++id) {
    const Variant v = make_variant(sweep, id);
    ASSERT_EQ(v.points.size(), 3u);
    // The middle vertex is within 0.5 of the midpoint (3, 1) of (0,0)-(6,2) in each coordinate.
    largest = std::max({largest, std::abs(v.points[1][0] - 3), std::abs(v.points[1][1] - 1)});
  }
  EXPECT_LE(largest, 0.5);
  EXPECT_GT(largest, 0.25);  // and they do spread
}

TEST(SweepFile, GroupingAndOutputKeys) {
  const Sweep sweep = parse(
      "scene = \"../zermelo_1.toml\"\n[grouping]\naction_tol = 1e-6\ndistance_tol = 0.01\n"
      "[output]\ndir = \"out/x\"\nplot = false\n");
  EXPECT_EQ(sweep.grouping.action_tol, 1e-6);
  EXPECT_EQ(sweep.grouping.distance_tol, 0.01);
  EXPECT_EQ(sweep.output_dir, "out/x");
  EXPECT_FALSE(sweep.plot);
}

TEST(SweepFile, TheShippedZermeloSweepParses) {
  const Sweep sweep = load_sweep(std::string(PARDEL_SCENES_DIR) + "/sweeps/zermelo_50.toml", {}, resolve);
  EXPECT_EQ(sweep.variant_count(), 50);
  EXPECT_EQ(sweep.configurations[0].options.method, Method::newton);
}

// ---------------------------------------------------------------------------------------------
// Bad files: the exact messages.

TEST(SweepFileErrors, UnknownTopLevelKeySuggestsTheNearest) {
  EXPECT_EQ(error_of("scene = \"../zermelo_1.toml\"\nrandom_guess = 3\n"),
            kName + ":2:1: error: unknown key 'random_guess'; did you mean 'random_guesses'?");
}

TEST(SweepFileErrors, UnknownNestedKeySuggestsTheNearest) {
  EXPECT_EQ(error_of("scene = \"../zermelo_1.toml\"\n[random_guesses]\ncout = 3\nspread = 1\n"),
            kName + ":3:1: error: unknown key 'random_guesses.cout'; did you mean 'random_guesses.count'?");
}

TEST(SweepFileErrors, UnrelatedKeyListsTheValidOnes) {
  EXPECT_EQ(error_of("scene = \"../zermelo_1.toml\"\n[grouping]\nzzzzzz = 1\n"),
            kName + ":3:1: error: unknown key 'grouping.zzzzzz' (valid keys in [grouping]: action_tol, distance_tol)");
}

TEST(SweepFileErrors, MissingScene) {
  EXPECT_EQ(error_of("[random_guesses]\ncount = 3\nspread = 1\n"),
            kName + ": error: missing key 'scene' (the base scene, relative to the sweep file)");
}

TEST(SweepFileErrors, SceneFileNotFound) {
  const std::string message = error_of("scene = \"../no_such_scene.toml\"\n");
  EXPECT_EQ(message, kName + ":1:9: error: scene file '" + std::string(PARDEL_SCENES_DIR) +
                         "/no_such_scene.toml' not found");
}

TEST(SweepFileErrors, TomlSyntaxErrorHasItsPosition) {
  const std::string message = error_of("scene = \"../zermelo_1.toml\"\n[random_guesses\n");
  EXPECT_EQ(message.rfind(kName + ":2:", 0), 0u) << message;
}

TEST(SweepFileErrors, NonAsciiOutsideStrings) {
  EXPECT_EQ(error_of("scene = \"../zermelo_1.toml\"\n\xc3\xa9 = 1\n"),
            kName + ":2:1: error: non-ASCII character outside a string or comment");
}

TEST(SweepFile, ByteOrderMarkIsSkippedAsInAScene) {
  EXPECT_EQ(parse("\xef\xbb\xbfscene = \"../zermelo_1.toml\"\n").variant_count(), 1);
  EXPECT_EQ(error_of("\xef\xbb\xbfscene = 1\n"), kName + ":1:9: error: scene must be a string, got an integer 1");
}

TEST(SweepFileErrors, RandomGuessesNeedBoxOrSpread) {
  EXPECT_EQ(error_of("scene = \"../zermelo_1.toml\"\n[random_guesses]\ncount = 3\n"),
            kName + ":2:1: error: random_guesses needs box = { min = [...], max = [...] } (vertices uniform in a "
                    "box) or spread = D (vertices within D of the straight line)");
  EXPECT_EQ(error_of("scene = \"../zermelo_1.toml\"\n[random_guesses]\ncount = 3\nspread = 1\n"
                     "box = { min = [0, 0], max = [1, 1] }\n"),
            kName + ":4:10: error: random_guesses: give either box or spread, not both");
}

TEST(SweepFileErrors, BadRandomValues) {
  EXPECT_EQ(error_of("scene = \"../zermelo_1.toml\"\n[random_guesses]\ncount = 0\nspread = 1\n"),
            kName + ":3:9: error: random_guesses.count must be between 1 and 1000000, got 0");
  EXPECT_EQ(error_of("scene = \"../zermelo_1.toml\"\n[random_guesses]\ncount = 2\nspread = -1\n"),
            kName + ":4:10: error: random_guesses.spread must be > 0, got -1");
  EXPECT_EQ(error_of("scene = \"../zermelo_1.toml\"\n[random_guesses]\ncount = 2\n"
                     "box = { min = [0, 0, 0], max = [1, 1] }\n"),
            kName + ":4:15: error: random_guesses.box.min has 3 values; expected 2 (model zermelo has coords x, y)");
  EXPECT_EQ(error_of("scene = \"../zermelo_1.toml\"\n[random_guesses]\ncount = 2\n"
                     "box = { min = [0, 2], max = [1, 1] }\n"),
            kName + ":4:29: error: random_guesses.box.max[1] = 1 is below min[1] = 2");
}

TEST(SweepFileErrors, BadListedGuess) {
  EXPECT_EQ(error_of("scene = \"../zermelo_1.toml\"\n[[guesses]]\npoints = [[0,0],[1,\"a\"],[6,2]]\n"),
            kName + ":3:20: error: guesses[0].points[1][1] must be a number, got a string \"a\"");
  EXPECT_EQ(error_of("scene = \"../zermelo_1.toml\"\n[[guesses]]\npoints = [[0,0]]\n"),
            kName + ":3:10: error: guesses[0].points must be an array of at least 2 points (model zermelo has "
                    "coords x, y)");
}

TEST(SweepFileErrors, BadVaryEntries) {
  EXPECT_EQ(error_of("scene = \"../zermelo_1.toml\"\n[[vary]]\nkey = \"params.s\"\nvalues = [1]\nfrom = 1\n"),
            kName + ":4:10: error: vary[0]: give either values or from, to and count, not both");
  EXPECT_EQ(error_of("scene = \"../zermelo_1.toml\"\n[[vary]]\nkey = \"params.s\"\nfrom = 1\n"),
            kName + ":2:1: error: vary[0] needs values = [...] or all of from, to and count");
  EXPECT_EQ(error_of("scene = \"../zermelo_1.toml\"\n[[vary]]\nkey = \"guess.kind\"\nvalues = [\"linear\"]\n"),
            kName + ":3:7: error: vary[0].key = \"guess.kind\": the guess comes from [[guesses]] and "
                    "[random_guesses], and outputs from [output] of the sweep file");
  EXPECT_EQ(error_of("scene = \"../zermelo_1.toml\"\n[[vary]]\nkey = \"grid.N\"\nvalues = [40]\n"
                     "[[vary]]\nkey = \"grid.N\"\nvalues = [80]\n"),
            kName + ":5:1: error: vary[1]: key 'grid.N' already varies in vary[0]");
}

TEST(SweepFileErrors, AVariedValueTheSceneRefusesNamesTheVaryEntryAndTheSceneError) {
  const std::string message =
      error_of("scene = \"../zermelo_1.toml\"\n[[vary]]\nkey = \"grid.N\"\nvalues = [40, 1]\n");
  EXPECT_EQ(message.rfind(kName + ":2:1: error: vary grid.N = 1: --set grid.N=1: error: grid.N must be between 2", 0),
            0u)
      << message;
  const std::string unknown = error_of("scene = \"../zermelo_1.toml\"\n[[vary]]\nkey = \"params.ss\"\nvalues = [1]\n");
  EXPECT_NE(unknown.find("vary params.ss = 1:"), std::string::npos) << unknown;
  EXPECT_NE(unknown.find("did you mean 'params.s'?"), std::string::npos) << unknown;
}

TEST(SweepFileErrors, AModelVariedIntoAnErrorOfTheBaseSceneNamesTheConfiguration) {
  // zermelo_1's boundary values have two coordinates; the harmonic oscillator has one: the base
  // scene's error at boundary.q0 comes with the configuration that brings it out.
  const std::string message =
      error_of("scene = \"../zermelo_1.toml\"\n[[vary]]\nkey = \"model\"\nvalues = [\"zermelo\", \"harmonic\"]\n");
  EXPECT_NE(message.find("boundary.q0 has 2 values; expected 1"), std::string::npos) << message;
  EXPECT_NE(message.find("; in the sweep's configuration vary model = \"harmonic\" (" + kName + ":2:1)"),
            std::string::npos)
      << message;
}

TEST(SweepFileErrors, BadSetEntryAndCommandLineSet) {
  EXPECT_EQ(error_of("scene = \"../zermelo_1.toml\"\nset = [\"solver.method\"]\n"),
            kName + ":2:8: error: set[0] = \"solver.method\" is not KEY=VALUE (e.g. solver.method=newton)");
  try {
    parse("scene = \"../zermelo_1.toml\"\n", {"solver.method=newtn"});
    FAIL() << "no error";
  } catch (const SceneError& error) {
    EXPECT_NE(std::string(error.what()).find("did you mean 'newton'?"), std::string::npos) << error.what();
  }
}

TEST(SweepFileErrors, NegativeGroupingTolerance) {
  EXPECT_EQ(error_of("scene = \"../zermelo_1.toml\"\n[grouping]\ndistance_tol = -1\n"),
            kName + ":3:16: error: grouping.distance_tol must be >= 0, got -1");
}

// Found by the contract of tests/fuzz/fuzz_sweep_reader.cpp (regressions in tests/fuzz/regressions_sweep/):
// a sweep file of five lines asked for gigabytes of random numbers, for a million scenes loaded
// before anything was solved, or for guesses whose vertices were not finite.
TEST(SweepFileErrors, TooManyConfigurations) {
  EXPECT_EQ(error_of("scene = \"../zermelo_1.toml\"\n[[vary]]\nkey = \"params.s\"\nfrom = 1\nto = 2\n"
                     "count = 1000000\n"),
            kName + ":6:9: error: vary[0].count must be between 1 and 10000, got 1000000");
  EXPECT_EQ(error_of("scene = \"../zermelo_1.toml\"\n[[vary]]\nkey = \"params.s\"\nfrom = 1\nto = 2\ncount = 200\n"
                     "[[vary]]\nkey = \"grid.N\"\nfrom = 10\nto = 109\ncount = 100\n"),
            kName + ": error: the varied keys give more than 10000 configurations (each is a scene loaded and "
                    "checked before anything is solved)");
}

TEST(SweepFileErrors, TooManyRandomNumbers) {
  EXPECT_EQ(error_of("scene = \"../zermelo_1.toml\"\n[random_guesses]\ncount = 1000000\ninterior_points = 1000\n"
                     "spread = 1\n"),
            kName + ":3:9: error: random_guesses: count x interior_points x coordinates = 1000000 x 1000 x 2 = "
                    "2000000000 random numbers, more than 10000000");
}

TEST(SweepFileErrors, GuessVerticesBeyondTheRangeOfADouble) {
  EXPECT_EQ(error_of("scene = \"../zermelo_1.toml\"\n[random_guesses]\ncount = 1\n"
                     "box = { min = [-1e308, 0], max = [1e308, 1] }\n"),
            kName + ":4:34: error: random_guesses.box: max[0] - min[0] = 1e+308 - (-1e+308) is beyond the range of "
                    "a double");
  EXPECT_EQ(error_of("scene = \"../zermelo_1.toml\"\nset = [\"boundary.q0=[-1e308, 0]\", \"boundary.qN=[1e308, 0]\"]\n"
                     "[random_guesses]\ncount = 1\nspread = 1\n"),
            kName + ":5:10: error: random_guesses.spread = 1: the vertices around the line from q0[0] = -1e+308 to "
                    "qN[0] = 1e+308 (configuration 0) are beyond the range of a double");
}

TEST(SweepFileErrors, MissingFile) {
  try {
    load_sweep("/nonexistent/sweep.toml", {}, resolve);
    FAIL() << "no error";
  } catch (const SceneError& error) {
    EXPECT_STREQ(error.what(), "/nonexistent/sweep.toml: error: cannot open sweep file: No such file or directory");
  }
}

}  // namespace
