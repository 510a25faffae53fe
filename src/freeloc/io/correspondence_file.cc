#include "freeloc/io/correspondence_file.h"

#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>

#include "freeloc/core/error.h"
#include "freeloc/io/file_util.h"
#include "freeloc/io/pyparse.h"

namespace freeloc::io {

std::vector<Eigen::Vector4d> ReadCorrespondenceFile(const std::string& path) {
  const std::vector<uint8_t> bytes = ReadFileBytes(path);  // a regular file, or an error naming it
  std::istringstream f(std::string(bytes.begin(), bytes.end()));
  std::vector<Eigen::Vector4d> rows;
  std::string line;
  int ln = 0;
  while (std::getline(f, line)) {
    ++ln;
    const std::string s = py::Strip(line);
    if (s.empty() || s[0] == '#') continue;
    std::istringstream is(s);
    std::vector<double> v;
    std::string tok;
    while (is >> tok) {
      double x;
      FREELOC_CHECK(py::ParseFloat(tok, &x), path << " line " << ln << ": '" << tok << "' is not a number");
      v.push_back(x);
    }
    FREELOC_CHECK(v.size() == 4,
                  path << " line " << ln << ": expected 4 numbers 'x_ref y_ref x_query y_query', got " << v.size());
    FREELOC_CHECK(std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]) && std::isfinite(v[3]),
                  path << " line " << ln << ": non-finite coordinate; remove NaN/inf rows");
    rows.emplace_back(v[0], v[1], v[2], v[3]);
  }
  return rows;
}

void WriteCorrespondenceFile(const std::string& path, const std::vector<Eigen::Vector4d>& rows) {
  std::string text;
  char buf[32];
  for (const auto& r : rows) {
    for (int k = 0; k < 4; ++k) {
      const auto res = std::to_chars(buf, buf + sizeof(buf), r(k));  // shortest form that reads back exactly
      text.append(buf, res.ptr);
      text += k < 3 ? ' ' : '\n';
    }
  }
  WriteFileAtomic(path, text.data(), text.size());
}

}  // namespace freeloc::io
