#include "freeloc/service/multipart.h"

#include <cctype>

#include "freeloc/core/error.h"

namespace freeloc::service::http {

namespace {

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// A header's parameter (`boundary=…` of a Content-Type), quotes removed; "" when absent.
std::string HeaderParam(const std::string& header, const std::string& name) {
  const std::string low = Lower(header);
  size_t p = 0;
  while ((p = low.find(name + "=", p)) != std::string::npos) {
    if (p == 0 || low[p - 1] == ';' || low[p - 1] == ' ') {
      std::string v = header.substr(p + name.size() + 1);
      v = v.substr(0, v.find(';'));
      while (!v.empty() && v.back() == ' ') v.pop_back();
      if (v.size() >= 2 && v.front() == '"' && v.back() == '"') v = v.substr(1, v.size() - 2);
      return v;
    }
    ++p;
  }
  return "";
}

}  // namespace

std::map<std::string, Part> ParseMultipart(const std::string& body, const std::string& content_type) {
  FREELOC_CHECK(Lower(content_type).rfind("multipart/form-data", 0) == 0,
                "request: expected multipart/form-data; got '" << SafeText(content_type, 80) << "'");
  const std::string boundary = HeaderParam(content_type, "boundary");
  FREELOC_CHECK(!boundary.empty() && boundary.size() <= 70,
                "request: the multipart Content-Type has no usable boundary (1 to 70 characters)");
  const std::string delim = "--" + boundary;
  std::map<std::string, Part> parts;
  size_t p = body.find(delim);
  FREELOC_CHECK(p != std::string::npos, "request: malformed multipart body (no boundary line)");
  while (true) {
    p += delim.size();
    if (body.compare(p, 2, "--") == 0) break;  // the closing delimiter
    FREELOC_CHECK(body.compare(p, 2, "\r\n") == 0, "request: malformed multipart body (a boundary line)");
    p += 2;
    const size_t head_end = body.find("\r\n\r\n", p);
    FREELOC_CHECK(head_end != std::string::npos && head_end - p <= 1024,
                  "request: malformed multipart body (a part's headers are missing or over 1 KiB)");
    Part part;
    std::string disposition;
    for (size_t q = p; q < head_end;) {
      size_t e = body.find("\r\n", q);
      if (e == std::string::npos || e > head_end) e = head_end;
      const std::string line = body.substr(q, e - q);
      const size_t colon = line.find(':');
      FREELOC_CHECK(colon != std::string::npos, "request: malformed multipart body (a part header without ':')");
      std::string value = line.substr(colon + 1);
      value.erase(0, value.find_first_not_of(' '));
      const std::string name = Lower(line.substr(0, colon));
      if (name == "content-disposition") disposition = value;
      if (name == "content-type") part.content_type = value;
      q = e + 2;
    }
    FREELOC_CHECK(Lower(disposition).rfind("form-data", 0) == 0,
                  "request: malformed multipart body (a part without Content-Disposition: form-data)");
    part.name = HeaderParam(disposition, "name");
    part.filename = HeaderParam(disposition, "filename");
    FREELOC_CHECK(!part.name.empty() && part.name.size() <= 64,
                  "request: malformed multipart body (a part's name is missing or over 64 bytes)");
    const size_t start = head_end + 4;
    const size_t end = body.find("\r\n" + delim, start);
    FREELOC_CHECK(end != std::string::npos, "request: malformed multipart body (a part without its closing boundary)");
    part.content = body.substr(start, end - start);
    FREELOC_CHECK(!parts.count(part.name),
                  "request: the field '" << SafeText(part.name, 64) << "' is sent twice; send each field once");
    FREELOC_CHECK(parts.size() < 16, "request: more than 16 multipart fields");
    const std::string key = part.name;
    parts[key] = std::move(part);
    p = end + 2;
  }
  return parts;
}

}  // namespace freeloc::service::http
