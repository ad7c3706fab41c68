/**
 * @file lag_parser.cpp
 * The .lag reader's entry points (parse_lag, parse_lag_file, lag_diagnostic) and the order of its
 * passes (Reader::read): every line is tokenized and its declaration recorded, then the lets in
 * order, L and clock are parsed with every name known, and the default discretization is chosen.
 */
#include "pardel_codegen/lag_parser.hpp"

#include <algorithm>
#include <sstream>
#include <string_view>

#include "lag_reader.hpp"
#include "pardel_codegen/discretizations.hpp"
#include "pardel/regular_file.hpp"

namespace pardel_codegen {
namespace lag {

LagModel Reader::read() {
  std::vector<Line> lines;
  for (int n = 1; n <= static_cast<int>(raw_lines_.size()); ++n) {
    Line l = tokenize(n);
    if (l.tokens.size() == 1) continue;  // blank or comment
    lines.push_back(l);
  }
  for (const Line& l : lines) read_declaration(l);

  auto missing = [&](const std::string& what) {
    int n = raw_lines_.empty() ? 1 : static_cast<int>(raw_lines_.size());
    int col = raw_lines_.empty() ? 1 : static_cast<int>(raw_lines_[n - 1].size()) + 1;
    fail(n, col, "missing " + what);
  };
  if (model_line_ == 0) missing("'model NAME' line");
  if (coords_line_ == 0) missing("'coords' line (the generalized coordinates)");
  if (!lagrangian_line_) missing("'L = ...' line (the Lagrangian)");
  // The kernels are dense in the point's dimension (3 dim^2 second derivatives a discretization,
  // each with its own expression): the generator's time grows faster than dim^2, past minutes and
  // gigabytes at dim = 1000, and the C++ compile of the emitted source with it.
  const std::size_t dim = static_cast<std::size_t>(model_.order) * model_.coords.size();
  if (dim > kMaxDimension)
    fail(coords_line_, 1,
         std::to_string(model_.coords.size()) + " coordinates" +
             (model_.order > 1 ? " of order " + std::to_string(model_.order) : std::string()) +
             " make a point of dimension " + std::to_string(dim) + "; pardel-gen writes dense kernels (3 dim^2 second "
             "derivatives each) and takes dimensions up to " + std::to_string(kMaxDimension));

  model_.coord_symbols.resize(static_cast<std::size_t>(model_.order) + 1);
  for (int k = 0; k <= model_.order; ++k) {
    for (const std::string& name : model_.coords) {
      model_.coord_symbols[static_cast<std::size_t>(k)].push_back(
          GiNaC::symbol(name + std::string(static_cast<std::size_t>(k), '\'')));
    }
  }

  std::string order_reason = "the model has order " + std::to_string(model_.order);
  for (const Line& l : let_lines_) {
    ExprContext ctx;
    ctx.max_derivative = model_.order;
    ctx.derivative_limit_reason = order_reason.c_str();
    ctx.let_limit_line = l.number;
    LetDecl& let = lets_[l.tokens[1].text];
    let.value = parse_full_expression(l, 3, ctx);
    let.defined = true;
  }
  const int after_all = static_cast<int>(raw_lines_.size()) + 1;
  {
    ExprContext ctx;
    ctx.max_derivative = model_.order;
    ctx.derivative_limit_reason = order_reason.c_str();
    ctx.let_limit_line = after_all;
    model_.lagrangian = parse_full_expression(*lagrangian_line_, 2, ctx);
    model_.lagrangian_line = lagrangian_line_->number;
    model_.lagrangian_column = lagrangian_line_->tokens[2].col;
  }
  if (clock_line_) {
    ExprContext ctx;
    ctx.max_derivative = model_.order == 1 ? 1 : model_.order - 1;
    std::string reason = "the clock of an order-" + std::to_string(model_.order) + " model may use derivatives up to order " +
                         std::to_string(ctx.max_derivative) + " only";
    ctx.derivative_limit_reason = reason.c_str();
    ctx.let_limit_line = after_all;
    model_.clock = parse_full_expression(*clock_line_, 2, ctx);
    model_.has_clock = true;
    model_.clock_line = clock_line_->number;
    model_.clock_column = clock_line_->tokens[2].col;
  }
  if (cost_line_ && model_.cost_kind == "clock" && !clock_line_) {
    fail(*cost_line_, cost_line_->tokens[3], "a cost that is the summed clock needs a 'clock = ...' declaration");
  }
  if (discretization_line_) {
    read_discretizations(*discretization_line_);
  } else {
    model_.discretizations.push_back(default_discretization(model_.order));
  }
  model_.filename = filename_;
  model_.source_lines = raw_lines_;
  model_.terms = std::move(terms_);
  return model_;
}

}  // namespace lag

bool LagModel::time_dependent() const {
  return lagrangian.has(time) || (has_clock && clock.has(time));
}

namespace {

/** Whether text is well-formed UTF-8 (a file that is not text shows its bytes as '?'). */
bool valid_utf8(const std::string& text) {
  for (std::size_t i = 0; i < text.size();) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    const int extra = c < 0x80 ? 0 : (c >> 5) == 0x6 ? 1 : (c >> 4) == 0xE ? 2 : (c >> 3) == 0x1E ? 3 : -1;
    if (extra < 0 || i + static_cast<std::size_t>(extra) >= text.size() + (extra == 0 ? 1 : 0)) return false;
    for (int k = 1; k <= extra; ++k)
      if ((static_cast<unsigned char>(text[i + static_cast<std::size_t>(k)]) >> 6) != 0x2) return false;
    i += static_cast<std::size_t>(extra) + 1;
  }
  return true;
}

}  // namespace

std::string lag_diagnostic(const std::string& filename, const std::string& source_line, int line, int col,
                           const std::string& message) {
  std::ostringstream out;
  out << filename << ':' << line << ':' << col << ": error: " << message << '\n';
  // A long line is shown as a window of kShown bytes around the column, cut between characters
  // and marked "..." where cut; control bytes, and every byte >= 0x80 of a line that is not UTF-8
  // (a binary file named as a model), as '?'.
  constexpr std::size_t kShown = 160;
  const std::size_t at = col > 0 ? static_cast<std::size_t>(col - 1) : 0;
  std::size_t begin = 0, end = source_line.size();
  if (end > kShown) {
    begin = at > kShown / 2 ? std::min(at - kShown / 2, end - kShown) : 0;
    end = std::min(end, begin + kShown);
    auto continuation = [&](std::size_t i) {
      return i < source_line.size() && (static_cast<unsigned char>(source_line[i]) >> 6) == 0x2;
    };
    while (begin > 0 && continuation(begin)) --begin;
    while (end < source_line.size() && continuation(end)) ++end;
  }
  const bool utf8 = valid_utf8(source_line);
  std::string shown = begin > 0 ? "..." : "";
  std::string caret = begin > 0 ? "   " : "";
  for (std::size_t i = begin; i < end; ++i) {
    const unsigned char c = static_cast<unsigned char>(source_line[i]);
    const char s = (c == '\t') ? '\t' : (c < 0x20 || c == 0x7f || (c >= 0x80 && !utf8)) ? '?' : static_cast<char>(c);
    shown += s;
    if (i < at) caret += (c == '\t') ? '\t' : ' ';
  }
  if (end < source_line.size()) shown += "...";
  while (caret.size() + begin - (begin > 0 ? 3 : 0) < at && caret.size() < kShown + 3) caret += ' ';
  out << "  " << shown << '\n' << "  " << caret << '^';
  return out.str();
}

LagModel parse_lag(const std::string& text, const std::string& filename) {
  // Editors on some systems start UTF-8 files with a byte-order mark: skipped (columns count
  // from the byte after it). A UTF-16 or UTF-32 file is refused by name rather than byte by byte.
  const std::string_view bom = "\xef\xbb\xbf";
  const bool has_bom = text.compare(0, bom.size(), bom) == 0;
  if (text.compare(0, 2, "\xff\xfe") == 0 || text.compare(0, 2, "\xfe\xff") == 0 ||
      text.compare(0, 4, std::string("\0\0\xfe\xff", 4)) == 0) {
    const std::string first_line = text.substr(0, text.find('\n'));
    const std::string message = "the file is UTF-16 or UTF-32 (it starts with a byte-order mark); save it as UTF-8";
    throw LagError(lag_diagnostic(filename, first_line, 1, 1, message), 1, 1, message);
  }
  lag::Reader reader(has_bom ? text.substr(bom.size()) : text, filename);
  return reader.read();
}

LagModel parse_lag_file(const std::string& path) {
  // A regular file of at most 1 MiB, checked before reading (a FIFO, a device, a folder or a
  // sparse file of gigabytes is refused by name); the diagnostic is located at 1:1.
  std::string text;
  try {
    text = pardel::read_regular_file(path, pardel::FileLimits::lag, ".lag file");
  } catch (const pardel::FileError& error) {
    throw LagError(path + ":1:1: error: " + error.reason(), 1, 1, error.reason());
  }
  return parse_lag(text, path);
}

}  // namespace pardel_codegen
