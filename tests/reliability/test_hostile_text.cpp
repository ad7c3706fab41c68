// .lag files with unusual text, given to the built `pardel` as a user would (`pardel kernels
// --model FILE.lag`, and a scene naming the file): byte-order marks, CRLF and lone CR line ends,
// NUL bytes, non-ASCII and UTF-16 text, names that are C++ keywords or alternative tokens or that of
// a bundled model, 10^4-deep nesting, an expression over a megabyte, a directory or nothing in
// place of the file. Accepted files must give the same kernels as their plain-ASCII twin (or the
// values computed here); refused ones exit with status 2 and FILE:LINE:COL, leave the model cache
// empty, and never crash or hang. The model cache is a scratch folder (PARDEL_CACHE_DIR).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "pardel_process.hpp"

namespace {

using namespace reliability;

/** Reads the number after `"KEY": ` in pardel kernels' JSON (the first element of an array). */
double json_value(const std::string& json, const std::string& key) {
  const std::size_t at = json.find("\"" + key + "\": ");
  if (at == std::string::npos) return std::nan("");
  std::size_t from = at + key.size() + 4;
  while (from < json.size() && json[from] == '[') ++from;
  return std::strtod(json.c_str() + from, nullptr);
}

class HostileText : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = scratch_folder("pardel_hostile_text");
    cache_ = dir_ / "cache";
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }

  /** Writes `bytes` as NAME and runs pardel kernels on it (order-1 model of one coordinate). */
  static Outcome kernels(const std::string& name, const std::string& bytes, const std::string& q0 = "1",
                         const std::string& q1 = "1.25") {
    write_text(dir_ / name, bytes);
    return run_pardel({"kernels", "--model", (dir_ / name).string(), "--disc", "trapezoid", "--h", "0.5", "--t0",
                       "0", "--t1", "0.5", "--q0", q0, "--q1", q1},
                      dir_ / (name + ".log"), {"PARDEL_CACHE_DIR=" + cache_.string()});
  }

  /** Entries of the model cache (finished or temporary). */
  static std::size_t cache_entries() {
    std::size_t n = 0;
    std::error_code ec;
    for (fs::directory_iterator it(cache_, ec); !ec && it != fs::directory_iterator(); it.increment(ec)) ++n;
    return n;
  }

  /** Refused: status 2, the diagnostic `FILE:where: error: message`, and nothing new in the cache. */
  static void expect_refused(const std::string& name, const std::string& bytes, const std::string& where,
                             const std::string& message) {
    const std::size_t before = cache_entries();
    const Outcome o = kernels(name, bytes);
    EXPECT_FALSE(o.timed_out);
    EXPECT_EQ(o.status, 2) << o.output;
    const std::string expected = (dir_ / name).string() + ":" + where + ": error: " + message;
    EXPECT_NE(o.output.find(expected), std::string::npos) << "expected: " << expected << "\ngot: " << o.output;
    EXPECT_EQ(o.output.find("internal error"), std::string::npos) << o.output;
    EXPECT_EQ(cache_entries(), before) << "a refused model left something in the cache";
  }

  static fs::path dir_, cache_;
};

fs::path HostileText::dir_, HostileText::cache_;

const std::string kPlain = "model text_twin\ncoords x\nparam k = 3\nL = x'^2/2 - k*x^2/2\n";

/** L = x'^2/2 - 3 x^2/2 by the trapezoid rule on h = 0.5 from x = 1 to x = 1.25. */
double plain_ld() {
  const double h = 0.5, a = 1, b = 1.25, v = (b - a) / h;
  return h / 2 * ((v * v / 2 - 3 * a * a / 2) + (v * v / 2 - 3 * b * b / 2));
}

std::string crlf(const std::string& text) {
  std::string out;
  for (char c : text) out += c == '\n' ? std::string("\r\n") : std::string(1, c);
  return out;
}

TEST_F(HostileText, PlainTwinGivesTheTrapezoidValue) {
  const Outcome o = kernels("plain.lag", kPlain);
  ASSERT_EQ(o.status, 0) << o.output;
  EXPECT_NEAR(json_value(o.output, "Ld"), plain_ld(), 1e-14);
}

TEST_F(HostileText, Utf8ByteOrderMarkIsSkipped) {
  const Outcome o = kernels("bom.lag", "\xef\xbb\xbf" + kPlain);
  ASSERT_EQ(o.status, 0) << o.output;
  EXPECT_NEAR(json_value(o.output, "Ld"), plain_ld(), 1e-14);
}

TEST_F(HostileText, CrlfLineEndsAreRead) {
  const Outcome o = kernels("crlf.lag", crlf(kPlain));
  ASSERT_EQ(o.status, 0) << o.output;
  EXPECT_NEAR(json_value(o.output, "Ld"), plain_ld(), 1e-14);
}

TEST_F(HostileText, ByteOrderMarkAndCrlfTogether) {
  const Outcome o = kernels("bom_crlf.lag", "\xef\xbb\xbf" + crlf(kPlain + "# a comment\n\n"));
  ASSERT_EQ(o.status, 0) << o.output;
  EXPECT_NEAR(json_value(o.output, "Ld"), plain_ld(), 1e-14);
}

TEST_F(HostileText, ColumnsAfterAByteOrderMarkCountFromTheText) {
  expect_refused("bom_error.lag", "\xef\xbb\xbfmodel 9m\ncoords x\nL = x^2\n", "1:7",
                 "'9m' is neither a number nor a name");
}

TEST_F(HostileText, ErrorInACrlfFileHasItsPositionAndNoCarriageReturn) {
  const std::string bytes = crlf("model m\ncoords x\nL = x^2 + y\n");
  expect_refused("crlf_error.lag", bytes, "3:11", "unknown identifier 'y'");
  const Outcome o = kernels("crlf_error.lag", bytes);
  EXPECT_EQ(o.output.find('\r'), std::string::npos) << "the diagnostic echoes a carriage return";
}

TEST_F(HostileText, LoneCarriageReturnsAreNamed) {
  expect_refused("cr.lag", "model m\rcoords x\rL = x^2\r", "1:8", "carriage return without a line feed");
}

TEST_F(HostileText, Utf16FileIsNamed) {
  expect_refused("utf16.lag", std::string("\xff\xfem\0o\0d\0", 8), "1:1", "the file is UTF-16 or UTF-32");
}

TEST_F(HostileText, ByteOrderMarkInsideTheFileIsRefused) {
  expect_refused("bom_inside.lag", "model m\ncoords x\nL = x^2 \xef\xbb\xbf\n", "3:9", "unexpected byte-order mark");
}

TEST_F(HostileText, NulAsFirstByte) {
  expect_refused("nul_first.lag", std::string("\0model m\ncoords x\nL = x^2\n", 24), "1:1", "unexpected byte 0x0");
}

TEST_F(HostileText, NulInsideTheModelName) {
  expect_refused("nul_name.lag", std::string("model a\0b\ncoords x\nL = x^2\n", 25), "1:8", "unexpected byte 0x0");
}

TEST_F(HostileText, Latin1Identifier) {
  expect_refused("latin1.lag", "model m\ncoords \xe9t\nL = x^2\n", "2:8", "unexpected byte 0xe9");
}

TEST_F(HostileText, Utf8LetName) {
  expect_refused("utf8_let.lag", "model m\ncoords x\nlet \xce\xbb = x\nL = x^2\n", "3:5",
                 "unexpected character '\xce\xbb' (U+03BB): names, numbers and operators are ASCII");
}

TEST_F(HostileText, Utf8CharactersOfFormulasAreNamedWithTheirAsciiSpelling) {
  expect_refused("utf8_square.lag", "model m\ncoords x\nL = x'\xc2\xb2\n", "3:7",
                 "unexpected character '\xc2\xb2' (U+00B2): write ^ for a power");
  expect_refused("utf8_times.lag", "model m\ncoords x\nL = 2\xc3\x97x'^2\n", "3:6",
                 "unexpected character '\xc3\x97' (U+00D7): write * for a product");
  expect_refused("utf8_prime.lag", "model m\ncoords x\nL = x\xe2\x80\xb2^2\n", "3:6",
                 "unexpected character '\xe2\x80\xb2' (U+2032): write ' for a time derivative");
  expect_refused("utf8_nbsp.lag", "model m\ncoords x\nL =\xc2\xa0x'^2\n", "3:4",
                 "unexpected character U+00A0: a space that is not ASCII");
  // Not UTF-8 (a lone continuation byte, a truncated sequence): the byte itself.
  expect_refused("utf8_broken.lag", "model m\ncoords x\nL = x'^2 \x80\n", "3:10", "unexpected byte 0x80");
  expect_refused("utf8_cut.lag", "model m\ncoords x\nL = x'^2 \xe2\x80\n", "3:10", "unexpected byte 0xe2");
}

TEST_F(HostileText, FormFeedInAnExpression) {
  expect_refused("form_feed.lag", "model m\ncoords x\nL = x^2\x0c\n", "3:8", "unexpected byte 0xc");
}

TEST_F(HostileText, CppKeywordsAndAlternativeTokensAsNames) {
  // and, or, not, xor, bitand are operators in C++ (alternative tokens), class and this keywords.
  const Outcome o = kernels("keywords.lag",
                            "model not\ncoords and or\nparam xor = 2\nlet class = and*or\nlet bitand = xor*class\n"
                            "L = (and'^2 + or'^2)/2 - bitand\n",
                            "1,2", "1.5,1");
  ASSERT_EQ(o.status, 0) << o.output;
  const double h = 0.5, va = (1.5 - 1) / h, vo = (1 - 2) / h;
  const double L0 = (va * va + vo * vo) / 2 - 2 * 1 * 2, L1 = (va * va + vo * vo) / 2 - 2 * 1.5 * 1;
  EXPECT_NEAR(json_value(o.output, "Ld"), h / 2 * (L0 + L1), 1e-13);
}

TEST_F(HostileText, ModelNamedLikeABundledModelUsesTheFile) {
  // The file's kernels, not those of the bundled fuel_nav (which has two coordinates).
  const Outcome o = kernels("fuel_nav.lag", "model fuel_nav\ncoords x\nparam k = 3\nL = x'^2/2 - k*x^2/2\n");
  ASSERT_EQ(o.status, 0) << o.output;
  EXPECT_NEAR(json_value(o.output, "Ld"), plain_ld(), 1e-14);
}

TEST_F(HostileText, NamesOfGeneratedSymbolsAsModelAndParams) {
  // The generated file defines <model>_trapezoid_full, <model>_model, pd_t0000...; a model named
  // after another model's symbols, with params named like its temporaries.
  const Outcome o = kernels("symbols.lag",
                            "model text_twin_trapezoid\ncoords x\nparam pd_t0000 = 3\nparam text_twin_model = 0\n"
                            "L = x'^2/2 - pd_t0000*x^2/2 + text_twin_model\n");
  ASSERT_EQ(o.status, 0) << o.output;
  EXPECT_NEAR(json_value(o.output, "Ld"), plain_ld(), 1e-14);
}

TEST_F(HostileText, TenThousandNestedParentheses) {
  expect_refused("deep_parens.lag",
                 "model m\ncoords x\nL = " + std::string(10000, '(') + "x" + std::string(10000, ')') + "\n", "3:205",
                 "expression is nested too deeply (at most 200 levels)");
}

TEST_F(HostileText, TenThousandNestedCalls) {
  std::string calls;
  for (int i = 0; i < 10000; ++i) calls += "sin(";
  expect_refused("deep_calls.lag", "model m\ncoords x\nL = " + calls + "x" + std::string(10000, ')') + "\n", "3:805",
                 "expression is nested too deeply");
}

TEST_F(HostileText, TenThousandUnaryMinusSigns) {
  expect_refused("deep_minus.lag", "model m\ncoords x\nL = " + std::string(10000, '-') + "x\n", "3:205",
                 "expression is nested too deeply");
}

TEST_F(HostileText, TenThousandChainedPowers) {
  std::string chain = "x";
  for (int i = 0; i < 10000; ++i) chain += "^x";
  expect_refused("deep_powers.lag", "model m\ncoords x\nL = " + chain + "\n", "3:405",
                 "expression is nested too deeply");
}

TEST_F(HostileText, ExpressionOverAMegabyte) {
  std::string sum = "x";
  while (sum.size() < (1u << 20)) sum += " + x";
  expect_refused("megabyte.lag", "model m\ncoords x\nL = " + sum + "\n", "1:1",
                 "is 1048599 bytes, more than the limit of 1048576 bytes (1 MiB) for a .lag file");
}

TEST_F(HostileText, EmptyFile) {
  expect_refused("empty.lag", "", "1:1", "missing 'model NAME' line");
}

TEST_F(HostileText, OnlyAByteOrderMark) {
  expect_refused("only_bom.lag", "\xef\xbb\xbf", "1:1", "missing 'model NAME' line");
}

TEST_F(HostileText, DirectoryInPlaceOfTheFile) {
  fs::create_directories(dir_ / "folder.lag");
  const Outcome o = run_pardel({"kernels", "--model", (dir_ / "folder.lag").string(), "--disc", "trapezoid", "--h",
                                "0.5", "--t0", "0", "--t1", "0.5", "--q0", "1", "--q1", "1"},
                               dir_ / "folder.log", {"PARDEL_CACHE_DIR=" + cache_.string()});
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find((dir_ / "folder.lag").string() + ":1:1: error: is a directory, not a .lag file"),
            std::string::npos)
      << o.output;
}

TEST_F(HostileText, SceneNamingARefusedModelPointsAtBothFiles) {
  // Through pardel solve: the scene's model key, then the .lag diagnostic; no output folder.
  write_text(dir_ / "deep.lag", "model m\ncoords x\nL = " + std::string(10000, '(') + "x" + std::string(10000, ')'));
  write_text(dir_ / "deep.toml",
             "model = \"deep.lag\"\n[grid]\nT = 1\nN = 10\n[boundary]\nq0 = [0]\nqN = [1]\n");
  const Outcome o = run_pardel({"solve", (dir_ / "deep.toml").string(), "--out", (dir_ / "deep_out").string(),
                                "--no-plot", "--quiet"},
                               dir_ / "deep_solve.log", {"PARDEL_CACHE_DIR=" + cache_.string()});
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find((dir_ / "deep.toml").string() + ":1:9: error: cannot load model 'deep.lag': "),
            std::string::npos)
      << o.output;
  EXPECT_NE(o.output.find("deep.lag:3:205: error: expression is nested too deeply"), std::string::npos) << o.output;
  EXPECT_FALSE(fs::exists(dir_ / "deep_out"));
}

TEST_F(HostileText, SceneNamingAMissingModelFile) {
  write_text(dir_ / "missing.toml",
             "model = \"no_such_file.lag\"\n[grid]\nT = 1\nN = 10\n[boundary]\nq0 = [0]\nqN = [1]\n");
  const Outcome o = run_pardel({"solve", (dir_ / "missing.toml").string(), "--out", (dir_ / "missing_out").string(),
                                "--no-plot", "--quiet"},
                               dir_ / "missing.log", {"PARDEL_CACHE_DIR=" + cache_.string()});
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find("missing.toml:1:9: error: cannot load model 'no_such_file.lag': no_such_file.lag:1:1: "
                          "error: cannot open .lag file: No such file or directory"),
            std::string::npos)
      << o.output;
  EXPECT_FALSE(fs::exists(dir_ / "missing_out"));
}

}  // namespace
