/**
 * @file lag_lexer.cpp
 * The lexer of the .lag reader: splits the text into lines (LF or CR LF) and each line into
 * identifiers (with their primes), numbers and operators, stopping at a '#' comment.
 */
#include <cctype>
#include <cstring>
#include <sstream>

#include "lag_reader.hpp"

namespace pardel_codegen::lag {

void Reader::split_lines(const std::string& text) {
  std::size_t start = 0;
  while (start <= text.size()) {
    std::size_t nl = text.find('\n', start);
    std::string line = text.substr(start, nl == std::string::npos ? std::string::npos : nl - start);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    raw_lines_.push_back(line);
    if (nl == std::string::npos) break;
    start = nl + 1;
  }
  if (!raw_lines_.empty() && raw_lines_.back().empty() && !text.empty() && text.back() == '\n') {
    raw_lines_.pop_back();
  }
}

Line Reader::tokenize(int number) const {
  Line l;
  l.number = number;
  l.text = raw_lines_[number - 1];
  const std::string& s = l.text;
  std::size_t i = 0;
  int last_end = 0;
  while (i < s.size()) {
    unsigned char c = static_cast<unsigned char>(s[i]);
    if (c == '#') break;
    if (c == ' ' || c == '\t') {
      ++i;
      continue;
    }
    Token t;
    t.col = static_cast<int>(i) + 1;
    if (std::isalpha(c) || c == '_') {
      std::size_t j = i;
      while (j < s.size() && (std::isalnum(static_cast<unsigned char>(s[j])) || s[j] == '_')) ++j;
      t.kind = Tok::ident;
      t.text = s.substr(i, j - i);
      if (t.text.size() > kMaxIdentifierLength) {
        fail(number, t.col,
             "identifier is too long (at most " + std::to_string(kMaxIdentifierLength) + " characters)");
      }
      while (j < s.size() && s[j] == '\'') {
        ++t.primes;
        ++j;
      }
      i = j;
    } else if (std::isdigit(c) || (c == '.' && i + 1 < s.size() && std::isdigit(static_cast<unsigned char>(s[i + 1])))) {
      std::size_t j = i;
      int dots = 0;
      while (j < s.size() && (std::isdigit(static_cast<unsigned char>(s[j])) || s[j] == '.')) {
        if (s[j] == '.') ++dots;
        ++j;
      }
      if (j < s.size() && (s[j] == 'e' || s[j] == 'E')) {
        std::size_t k = j + 1;
        if (k < s.size() && (s[k] == '+' || s[k] == '-')) ++k;
        if (k < s.size() && std::isdigit(static_cast<unsigned char>(s[k]))) {
          while (k < s.size() && std::isdigit(static_cast<unsigned char>(s[k]))) ++k;
          j = k;
        }
      }
      t.kind = Tok::number;
      t.text = s.substr(i, j - i);
      if (dots > 1) fail(number, t.col, "malformed number '" + t.text + "'");
      if (t.text.size() > 40) fail(number, t.col, "number is too long (at most 40 characters)");
      if (j < s.size() && (std::isalpha(static_cast<unsigned char>(s[j])) || s[j] == '_')) {
        std::size_t k = j;
        while (k < s.size() && (std::isalnum(static_cast<unsigned char>(s[k])) || s[k] == '_')) ++k;
        fail(number, t.col,
             "'" + s.substr(i, k - i) + "' is neither a number nor a name (names start with a letter; "
             "write 2*x for a product)");
      }
      i = j;
    } else if (std::strchr("+-*/^(),=", static_cast<int>(c)) != nullptr && c != 0) {
      t.kind = Tok::op;
      t.text = std::string(1, static_cast<char>(c));
      ++i;
    } else if (c == '\'') {
      fail(number, t.col, "a prime (') must follow a coordinate name");
    } else {
      std::ostringstream msg;
      if (s.compare(i, 3, "\xef\xbb\xbf") == 0) {
        msg << "unexpected byte-order mark (U+FEFF; only allowed as the first bytes of the file)";
      } else if (c == '\r') {
        msg << "carriage return without a line feed (lines must end with LF or CR LF)";
      } else if (c >= 0x20 && c < 0x7f) {
        msg << "unexpected character '" << static_cast<char>(c) << "'";
      } else {
        msg << "unexpected byte 0x" << std::hex << static_cast<int>(c);
      }
      fail(number, t.col, msg.str());
    }
    last_end = static_cast<int>(i);
    l.tokens.push_back(t);
  }
  Token end;
  end.kind = Tok::end;
  end.col = last_end + 1;
  l.end_col = last_end + 1;
  l.tokens.push_back(end);
  return l;
}

}  // namespace pardel_codegen::lag
