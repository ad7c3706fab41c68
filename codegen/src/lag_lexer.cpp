/**
 * @file lag_lexer.cpp
 * The lexer of the .lag reader: splits the text into lines (LF or CR LF) and each line into
 * identifiers (with their primes), numbers and operators, stopping at a '#' comment.
 */
#include <cctype>
#include <cstdio>
#include <cstring>
#include <sstream>

#include "lag_reader.hpp"

namespace pardel_codegen::lag {

namespace {

/** The code point of the well-formed UTF-8 sequence at s[i] (its length in *len), or -1. */
long utf8_at(const std::string& s, std::size_t i, std::size_t* len) {
  const unsigned char c = static_cast<unsigned char>(s[i]);
  const std::size_t n = c >= 0xf0 && c < 0xf5 ? 4 : c >= 0xe0 ? 3 : c >= 0xc2 && c < 0xe0 ? 2 : 0;
  if (n == 0 || i + n > s.size()) return -1;
  long cp = c & (n == 2 ? 0x1f : n == 3 ? 0x0f : 0x07);
  for (std::size_t k = 1; k < n; ++k) {
    const unsigned char b = static_cast<unsigned char>(s[i + k]);
    if ((b & 0xc0) != 0x80) return -1;
    cp = (cp << 6) | (b & 0x3f);
  }
  if ((n == 3 && cp < 0x800) || (n == 4 && (cp < 0x10000 || cp > 0x10ffff)) || (cp >= 0xd800 && cp < 0xe000))
    return -1;
  *len = n;
  return cp;
}

/** What to write instead of a non-ASCII character that people type in formulas. */
const char* ascii_instead(long cp) {
  if (cp == 0xb2 || cp == 0xb3 || cp == 0xb9 || (cp >= 0x2070 && cp <= 0x2079)) return "write ^ for a power (x^2)";
  if (cp == 0xd7 || cp == 0xb7 || cp == 0x22c5 || cp == 0x2219) return "write * for a product";
  if (cp == 0x2032 || cp == 0x2019 || cp == 0x2033) return "write ' for a time derivative (x', x'')";
  if (cp == 0x2212 || cp == 0x2013) return "write - for a minus";
  if (cp == 0xf7 || cp == 0x2215) return "write / for a quotient";
  if (cp == 0xa0 || (cp >= 0x2000 && cp <= 0x200b) || cp == 0x202f || cp == 0x3000) return "a space that is not ASCII";
  return "names, numbers and operators are ASCII (spell Greek letters out: theta, lambda)";
}

}  // namespace

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
      long cp = -1;  // the code point of a UTF-8 character here
      if (s.compare(i, 3, "\xef\xbb\xbf") == 0) {
        msg << "unexpected byte-order mark (U+FEFF; only allowed as the first bytes of the file)";
      } else if (c == '\r') {
        msg << "carriage return without a line feed (lines must end with LF or CR LF)";
      } else if (c >= 0x20 && c < 0x7f) {
        msg << "unexpected character '" << static_cast<char>(c) << "'";
      } else if (std::size_t len = 0; c >= 0x80 && (cp = utf8_at(s, i, &len)) >= 0) {
        char code[16];
        std::snprintf(code, sizeof code, "U+%04lX", cp);
        const bool visible = cp > 0xa0 && !(cp >= 0x2000 && cp <= 0x200f) && !(cp >= 0x2028 && cp <= 0x202f) &&
                             !(cp >= 0x205f && cp <= 0x206f) && cp != 0x3000;
        msg << "unexpected character " << (visible ? "'" + s.substr(i, len) + "' (" + code + ")" : std::string(code))
            << ": " << ascii_instead(cp);
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
