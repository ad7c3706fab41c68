// Tests of the pardel-gen command and the render script as a flow: exit codes, diagnostics on
// stderr, no partial output on error, byte-identical output across runs, banners, --stats, and the
// IR's free text (the source name) read back by Python's json module and by nlohmann-json.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

namespace {

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

bool exists(const std::string& path) {
  struct stat st;
  return ::stat(path.c_str(), &st) == 0;
}

/** `bytes` as lowercase hex digits, two per byte. */
std::string hex(const std::string& bytes) {
  std::string out;
  char buf[3];
  for (unsigned char c : bytes) {
    std::snprintf(buf, sizeof buf, "%02x", c);
    out += buf;
  }
  return out;
}

/** The C string literal render.py writes for `bytes`: '"' and '\\' escaped, printable ASCII but
 *  '?' as is, every other byte as three octal digits. */
std::string c_literal(const std::string& bytes) {
  std::string out = "\"";
  char buf[8];
  for (unsigned char c : bytes) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += static_cast<char>(c);
    } else if (c >= 0x20 && c < 0x7f && c != '?') {
      out += static_cast<char>(c);
    } else {
      std::snprintf(buf, sizeof buf, "\\%03o", c);
      out += buf;
    }
  }
  return out + "\"";
}

/** A scratch folder of its own for each test. */
class PardelGen : public ::testing::Test {
 protected:
  void SetUp() override {
    char pattern[] = "/tmp/pardel_gen_test_XXXXXX";
    ASSERT_NE(::mkdtemp(pattern), nullptr);
    dir_ = pattern;
  }
  void TearDown() override { std::system(("rm -rf '" + dir_ + "'").c_str()); }

  /** Runs a shell command; returns its exit status. */
  int run(const std::string& command) {
    int status = std::system(command.c_str());
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }
  /** Runs `argv` without a shell, so that its arguments may hold any byte but NUL, with stdout
   *  and stderr into the scratch folder; returns its exit status. */
  int run_argv(const std::vector<std::string>& argv) {
    const pid_t pid = ::fork();
    if (pid == 0) {
      const int out = ::open((dir_ + "/stdout").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
      const int err = ::open((dir_ + "/stderr").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
      if (out < 0 || err < 0 || ::dup2(out, 1) < 0 || ::dup2(err, 2) < 0) ::_exit(127);
      std::vector<char*> args;
      for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
      args.push_back(nullptr);
      ::execv(args[0], args.data());
      ::_exit(127);
    }
    int status = 0;
    if (pid < 0 || ::waitpid(pid, &status, 0) != pid) return -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }
  /** Whether Python's json module reads the IR at `ir` with model.source equal to `bytes` (its
   *  lone surrogates taken back to bytes as render.py does, with surrogateescape). */
  bool python_reads_source(const std::string& ir, const std::string& bytes) {
    const std::string script =
        "import json, sys\n"
        "with open(sys.argv[1], encoding=\"utf-8\") as f:\n"
        "    source = json.load(f)[\"model\"][\"source\"]\n"
        "sys.exit(0 if source.encode(\"utf-8\", \"surrogateescape\").hex() == sys.argv[2] else 3)\n";
    return run_argv({PARDEL_PYTHON_PATH, "-c", script, ir, hex(bytes)}) == 0;
  }
  int gen(const std::string& args) {
    return run(std::string(PARDEL_GEN_PATH) + " " + args + " > '" + dir_ + "/stdout' 2> '" + dir_ + "/stderr'");
  }
  std::string model(const std::string& name) const {
    return std::string(PARDEL_CODEGEN_TEST_DIR) + "/models/" + name + ".lag";
  }
  std::string bad(const std::string& name) const {
    return std::string(PARDEL_CODEGEN_TEST_DIR) + "/bad_lag/" + name + ".lag";
  }
  std::string dir_;
};

TEST_F(PardelGen, WritesTheIrAndExitsZero) {
  const std::string out = dir_ + "/m.json";
  ASSERT_EQ(gen(model("cgtest_order2") + " -o " + out + " --source-name tests/m.lag"), 0) << read_file(dir_ + "/stderr");
  const std::string ir = read_file(out);
  EXPECT_NE(ir.find("\"format\": \"pardel-ir\""), std::string::npos);
  EXPECT_NE(ir.find("\"source\": \"tests/m.lag\""), std::string::npos);
  EXPECT_NE(ir.find("\"function\": \"cgtest_order2_gauss2_full\""), std::string::npos);
  EXPECT_NE(ir.find("\"function\": \"cgtest_order2_trapezoid_alpha_1_2_sweep\""), std::string::npos);
  EXPECT_NE(ir.find("\"function\": \"cgtest_order2_clock\""), std::string::npos);
}

TEST_F(PardelGen, BadInputExitsOneWithADiagnosticAndWritesNothing) {
  const std::string out = dir_ + "/bad.json";
  EXPECT_EQ(gen(bad("unknown_identifier") + " -o " + out), 1);
  EXPECT_FALSE(exists(out));
  const std::string err = read_file(dir_ + "/stderr");
  EXPECT_NE(err.find(bad("unknown_identifier") + ":4:16: error: unknown identifier 'z'"), std::string::npos) << err;
  EXPECT_NE(err.find("\n                 ^"), std::string::npos) << err;
}

TEST_F(PardelGen, BadInputLeavesAnEarlierOutputUntouched) {
  const std::string out = dir_ + "/kept.json";
  { std::ofstream(out) << "previous"; }
  EXPECT_EQ(gen(bad("duplicate_lagrangian") + " -o " + out), 1);
  EXPECT_EQ(read_file(out), "previous");
}

// trapezoid(alpha=0) is not regular for any L: refused at its name unless allowed.
TEST_F(PardelGen, AlphaZeroIsRefusedAtItsNameUnlessAllowed) {
  const std::string lag = dir_ + "/alpha0.lag";
  { std::ofstream(lag) << "model alpha0\norder 2\ncoords x\nL = x''^2/2\ndiscretizations trapezoid(alpha=0)\n"; }
  EXPECT_EQ(gen(lag + " -o " + dir_ + "/alpha0.json"), 1);
  EXPECT_FALSE(exists(dir_ + "/alpha0.json"));
  const std::string err = read_file(dir_ + "/stderr");
  EXPECT_NE(err.find(lag + ":5:17: error: model 'alpha0': discretization 'trapezoid(alpha=0)' is not regular"),
            std::string::npos) << err;
  ASSERT_EQ(gen(lag + " -o " + dir_ + "/alpha0.json --allow-singular"), 0) << read_file(dir_ + "/stderr");
  EXPECT_NE(read_file(dir_ + "/alpha0.json").find("\"name\": \"trapezoid(alpha=0)\""), std::string::npos);
  EXPECT_NE(read_file(dir_ + "/stderr").find(lag + ":5:17: warning: "), std::string::npos) << read_file(dir_ + "/stderr");
}

// A model whose W is singular everywhere: exit 1, the diagnostic on stderr, nothing written;
// --allow-singular generates it and prints the same finding as a warning.
TEST_F(PardelGen, SingularModelIsRefusedUnlessAllowed) {
  const std::string lag = std::string(PARDEL_CODEGEN_TEST_DIR) + "/regularity/jerk_missing.lag";
  const std::string out = dir_ + "/jm.json";
  EXPECT_EQ(gen(lag + " -o " + out), 1);
  EXPECT_FALSE(exists(out));
  std::string err = read_file(dir_ + "/stderr");
  EXPECT_NE(err.find(lag + ":5:5: error: model 'jerk_missing' is not regular"), std::string::npos) << err;
  EXPECT_NE(err.find("L does not depend on a'''"), std::string::npos) << err;
  EXPECT_NE(err.find("Newton's and Jacobi's iterations need W invertible"), std::string::npos) << err;
  EXPECT_EQ(gen(lag + " --stats"), 1);  // every mode checks
  ASSERT_EQ(gen(lag + " -o " + out + " --allow-singular"), 0) << read_file(dir_ + "/stderr");
  EXPECT_TRUE(exists(out));
  err = read_file(dir_ + "/stderr");
  EXPECT_NE(err.find(lag + ":5:5: warning: model 'jerk_missing' is not regular"), std::string::npos) << err;
}

// A model singular on part of its domain only is generated, with a warning on stderr.
TEST_F(PardelGen, PartlySingularModelIsGeneratedWithAWarning) {
  const std::string lag = std::string(PARDEL_CODEGEN_TEST_DIR) + "/regularity/cubic_fold.lag";
  ASSERT_EQ(gen(lag + " -o " + dir_ + "/cf.json"), 0) << read_file(dir_ + "/stderr");
  const std::string err = read_file(dir_ + "/stderr");
  EXPECT_NE(err.find(lag + ":5:5: warning: model 'cubic_fold'"), std::string::npos) << err;
  EXPECT_NE(err.find("vanishes near s = 1"), std::string::npos) << err;
}

TEST_F(PardelGen, MissingInputAndBadUsageAreReported) {
  EXPECT_EQ(gen(dir_ + "/none.lag -o " + dir_ + "/x.json"), 1);
  EXPECT_NE(read_file(dir_ + "/stderr").find("none.lag:1:1: error: cannot open .lag file: No such file or directory"),
            std::string::npos);
  EXPECT_EQ(gen("--frobnicate"), 2);
  EXPECT_EQ(gen(model("cgtest_order2")), 2);  // nothing to do
  EXPECT_EQ(gen(""), 2);
}

TEST_F(PardelGen, OutputIsByteIdenticalAcrossRuns) {
  for (int i = 0; i < 3; ++i) {
    ASSERT_EQ(gen(model("cgtest_functions") + " -o " + dir_ + "/run" + std::to_string(i) + ".json"), 0);
  }
  const std::string first = read_file(dir_ + "/run0.json");
  EXPECT_FALSE(first.empty());
  EXPECT_EQ(first, read_file(dir_ + "/run1.json"));
  EXPECT_EQ(first, read_file(dir_ + "/run2.json"));
}

// GiNaC orders terms by address-seeded hashes; with address randomization left on, the output
// must still not change (the CSE orders by its own structural hashes, constants stay exact).
TEST_F(PardelGen, OutputDoesNotDependOnGinacTermOrder) {
  ASSERT_EQ(gen(model("cgtest_order2") + " -o " + dir_ + "/ref.json"), 0);
  const std::string ref = read_file(dir_ + "/ref.json");
  for (int i = 0; i < 4; ++i) {
    const std::string out = dir_ + "/aslr" + std::to_string(i) + ".json";
    ASSERT_EQ(run("PARDEL_GEN_NO_REEXEC=1 " + std::string(PARDEL_GEN_PATH) + " " + model("cgtest_order2") + " -o " + out), 0);
    EXPECT_EQ(read_file(out), ref) << "run " << i;
  }
}

TEST_F(PardelGen, RenderWritesHeaderAndSourceDeterministically) {
  const std::string ir = dir_ + "/m.json";
  ASSERT_EQ(gen(model("cgtest_order2") + " -o " + ir + " --source-name tests/codegen/models/cgtest_order2.lag"), 0);
  const std::string render = std::string(PARDEL_PYTHON_PATH) + " " + PARDEL_RENDER_SCRIPT_PATH + " " + ir;
  ASSERT_EQ(run(render + " --out-dir " + dir_ + "/a"), 0);
  ASSERT_EQ(run(render + " --out-dir " + dir_ + "/b"), 0);
  for (const char* ext : {".hpp", ".cpp"}) {
    const std::string a = read_file(dir_ + "/a/cgtest_order2" + ext);
    EXPECT_EQ(a, read_file(dir_ + "/b/cgtest_order2" + ext));
    EXPECT_EQ(a.rfind("// Generated by pardel-gen ", 0), 0u);
    EXPECT_NE(a.find("from tests/codegen/models/cgtest_order2.lag. DO NOT EDIT."), std::string::npos);
  }
  EXPECT_NE(read_file(dir_ + "/a/cgtest_order2.hpp").find("#include \"pardel/kernel_abi.h\""), std::string::npos);
  EXPECT_NE(read_file(dir_ + "/a/cgtest_order2.cpp").find("extern \"C\" const pardel_model cgtest_order2_model"),
            std::string::npos);
}

// The source name is the IR's only free text (.lag names are C identifiers): every character JSON
// escapes, every control character, DEL and UTF-8 of 2, 3 and 4 bytes survive the IR, read back by
// Python's json module and by nlohmann-json, and reach the rendered model's source string.
TEST_F(PardelGen, IrKeepsEveryJsonSpecialCharacterOfTheSourceName) {
  std::string name = "dir/\"quoted\" back\\slash/";
  for (char c = 1; c < 0x20; ++c) name += c;
  name += "\x7f caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x98\x80 \\u0000 \\n/m.lag";
  const std::string ir = dir_ + "/m.json";
  ASSERT_EQ(run_argv({PARDEL_GEN_PATH, model("cgtest_order2"), "-o", ir, "--source-name", name}), 0)
      << read_file(dir_ + "/stderr");
  EXPECT_TRUE(python_reads_source(ir, name)) << read_file(dir_ + "/stderr");
  const nlohmann::json j = nlohmann::json::parse(read_file(ir), nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << "nlohmann-json cannot read the IR";
  EXPECT_EQ(j["model"]["source"].get<std::string>(), name);
  EXPECT_EQ(j["model"]["name"].get<std::string>(), "cgtest_order2");
  ASSERT_EQ(run_argv({PARDEL_PYTHON_PATH, PARDEL_RENDER_SCRIPT_PATH, ir, "--out-dir", dir_ + "/o"}), 0)
      << read_file(dir_ + "/stderr");
  EXPECT_NE(read_file(dir_ + "/o/cgtest_order2.cpp").find("    " + c_literal(name) + ",\n"), std::string::npos)
      << c_literal(name);
}

// A source name that is not UTF-8 (a file name in another encoding): its bytes are written as the
// lone surrogates of Python's surrogateescape and come back unchanged in the rendered source string.
TEST_F(PardelGen, IrKeepsTheBytesOfASourceNameThatIsNotUtf8) {
  const std::string name = "mod\xe8le/\xff\xc3(\xed\xa0\x80)\xf4\x90\x80\x80 ok\xc3\xa9.lag";
  const std::string ir = dir_ + "/m.json";
  ASSERT_EQ(run_argv({PARDEL_GEN_PATH, model("cgtest_order2"), "-o", ir, "--source-name", name}), 0)
      << read_file(dir_ + "/stderr");
  EXPECT_NE(read_file(ir).find("\"source\": \"mod\\udce8le/\\udcff\\udcc3("), std::string::npos) << read_file(ir);
  EXPECT_TRUE(python_reads_source(ir, name)) << read_file(dir_ + "/stderr");
  ASSERT_EQ(run_argv({PARDEL_PYTHON_PATH, PARDEL_RENDER_SCRIPT_PATH, ir, "--out-dir", dir_ + "/o"}), 0)
      << read_file(dir_ + "/stderr");
  EXPECT_NE(read_file(dir_ + "/o/cgtest_order2.cpp").find("    " + c_literal(name) + ",\n"), std::string::npos)
      << c_literal(name);
}

TEST_F(PardelGen, RenderRejectsAMalformedIr) {
  { std::ofstream(dir_ + "/junk.json") << "{\"format\": \"something else\"}"; }
  EXPECT_EQ(run(std::string(PARDEL_PYTHON_PATH) + " " + PARDEL_RENDER_SCRIPT_PATH + " " + dir_ +
                "/junk.json --out-dir " + dir_ + "/o 2> /dev/null"),
            1);
  EXPECT_FALSE(exists(dir_ + "/o/junk.cpp"));
}

TEST_F(PardelGen, StatsReportOperationCountsBeforeAndAfterCse) {
  ASSERT_EQ(gen(model("cgtest_order2") + " --stats"), 0);
  const std::string table = read_file(dir_ + "/stdout");
  EXPECT_NE(table.find("ops before"), std::string::npos);
  EXPECT_NE(table.find("gauss2"), std::string::npos);
  EXPECT_NE(table.find("sweep"), std::string::npos);
  ASSERT_EQ(gen(model("cgtest_order2") + " --stats-json"), 0);
  const std::string json = read_file(dir_ + "/stdout");
  EXPECT_NE(json.find("\"ops_after_cse\""), std::string::npos);
  EXPECT_NE(json.find("\"op_convention\""), std::string::npos);
}

}  // namespace
