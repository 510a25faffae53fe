#include "freeloc/io/pyparse.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <limits>

namespace freeloc::io::py {

namespace {
bool IsPySpace(unsigned char c) {
  return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f' || (c >= 0x1c && c <= 0x1f);
}

// digitpart: digit (["_"] digit)*; advances i; returns false when no digit at i.
bool DigitPart(const std::string& s, size_t* i, std::string* digits) {
  if (*i >= s.size() || !std::isdigit(static_cast<unsigned char>(s[*i]))) return false;
  digits->push_back(s[(*i)++]);
  while (*i < s.size()) {
    if (std::isdigit(static_cast<unsigned char>(s[*i]))) {
      digits->push_back(s[(*i)++]);
    } else if (s[*i] == '_' && *i + 1 < s.size() && std::isdigit(static_cast<unsigned char>(s[*i + 1]))) {
      ++*i;
    } else {
      break;
    }
  }
  return true;
}

std::string Lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}
}  // namespace

std::string Strip(const std::string& s) {
  size_t b = 0, e = s.size();
  while (b < e && IsPySpace(static_cast<unsigned char>(s[b]))) ++b;
  while (e > b && IsPySpace(static_cast<unsigned char>(s[e - 1]))) --e;
  return s.substr(b, e - b);
}

bool ParseFloat(const std::string& in, double* out) {
  const std::string s = Strip(in);
  if (s.empty()) return false;
  size_t i = 0;
  std::string clean;
  if (s[i] == '+' || s[i] == '-') clean.push_back(s[i++]);
  const std::string rest = Lower(s.substr(i));
  if (rest == "inf" || rest == "infinity") {
    *out = clean == "-" ? -std::numeric_limits<double>::infinity() : std::numeric_limits<double>::infinity();
    return true;
  }
  if (rest == "nan") {
    *out = std::numeric_limits<double>::quiet_NaN();
    return true;
  }
  bool int_part = DigitPart(s, &i, &clean);
  bool frac_part = false;
  if (i < s.size() && s[i] == '.') {
    clean.push_back(s[i++]);
    frac_part = DigitPart(s, &i, &clean);
  }
  if (!int_part && !frac_part) return false;
  if (i < s.size() && (s[i] == 'e' || s[i] == 'E')) {
    clean.push_back('e');
    ++i;
    if (i < s.size() && (s[i] == '+' || s[i] == '-')) clean.push_back(s[i++]);
    if (!DigitPart(s, &i, &clean)) return false;
  }
  if (i != s.size()) return false;
  // strtod in the C locale (the decimal point is '.').
  *out = std::strtod(clean.c_str(), nullptr);
  return true;
}

bool ParseInt(const std::string& in, int64_t* out) {
  const std::string s = Strip(in);
  size_t i = 0;
  std::string clean;
  if (i < s.size() && (s[i] == '+' || s[i] == '-')) clean.push_back(s[i++]);
  if (!DigitPart(s, &i, &clean) || i != s.size()) return false;
  errno = 0;
  const long long v = std::strtoll(clean.c_str(), nullptr, 10);
  if (errno == ERANGE) return false;
  *out = v;
  return true;
}

std::vector<std::string> SplitSpace(const std::string& s) {
  std::vector<std::string> parts;
  size_t start = 0;
  while (true) {
    const size_t p = s.find(' ', start);
    if (p == std::string::npos) {
      parts.push_back(s.substr(start));
      return parts;
    }
    parts.push_back(s.substr(start, p - start));
    start = p + 1;
  }
}

std::vector<std::string> SplitLines(const std::string& text) {
  std::vector<std::string> lines;
  ForEachLine(text, [&](const std::string& line) { lines.push_back(line); });
  return lines;
}

void ForEachLine(const std::string& text, const std::function<void(const std::string& line)>& fn) {
  std::string cur;
  bool pending = false;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\n' || c == '\r') {
      fn(cur);
      cur.clear();
      pending = false;
      if (c == '\r' && i + 1 < text.size() && text[i + 1] == '\n') ++i;
    } else {
      cur.push_back(c);
      pending = true;
    }
  }
  if (pending) fn(cur);
}

bool IsValidUtf8(const std::string& b) {
  size_t i = 0;
  while (i < b.size()) {
    const unsigned char c = b[i];
    int n = 0;
    uint32_t cp = 0;
    if (c < 0x80) {
      ++i;
      continue;
    } else if ((c & 0xE0) == 0xC0) {
      n = 1;
      cp = c & 0x1F;
    } else if ((c & 0xF0) == 0xE0) {
      n = 2;
      cp = c & 0x0F;
    } else if ((c & 0xF8) == 0xF0) {
      n = 3;
      cp = c & 0x07;
    } else {
      return false;
    }
    for (int k = 1; k <= n; ++k) {
      if (i + k >= b.size()) return false;
      const unsigned char d = b[i + k];
      if ((d & 0xC0) != 0x80) return false;
      cp = (cp << 6) | (d & 0x3F);
    }
    // Overlong forms, surrogates and values past U+10FFFF are invalid (as Python's strict decoder says).
    if ((n == 1 && cp < 0x80) || (n == 2 && cp < 0x800) || (n == 3 && cp < 0x10000) || cp > 0x10FFFF ||
        (cp >= 0xD800 && cp <= 0xDFFF))
      return false;
    i += n + 1;
  }
  return true;
}

std::string FrameSlice(const std::string& name) {
  // Byte offsets of each code point.
  std::vector<size_t> starts;
  for (size_t i = 0; i < name.size(); ++i)
    if ((static_cast<unsigned char>(name[i]) & 0xC0) != 0x80) starts.push_back(i);
  const long n = static_cast<long>(starts.size());
  const long b = std::max<long>(n - 9, 0);
  const long e = std::max<long>(n - 4, 0);
  if (e <= b) return "";
  const size_t bb = starts[b];
  const size_t eb = e < n ? starts[e] : name.size();
  return name.substr(bb, eb - bb);
}

bool FrameKey(const std::string& name, int64_t* key) { return ParseInt(FrameSlice(name), key); }

}  // namespace freeloc::io::py
