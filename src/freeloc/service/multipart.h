// The multipart/form-data body of the service's uploads, parsed by freeloc (service/http.h): bounded in parts (16),
// names (64 bytes) and part headers (1 KiB); a part's bytes are kept as sent. Depends on core only (the fuzz target
// fuzz/multipart.cc builds it alone).
#pragma once

#include <map>
#include <string>

namespace freeloc::service::http {

struct Part {
  std::string name, filename, content_type, content;
};

// The form fields of a multipart/form-data body, by name; throws freeloc::Error naming what is malformed (at most 16
// parts, names of at most 64 bytes, part headers of at most 1 KiB, each name once).
std::map<std::string, Part> ParseMultipart(const std::string& body, const std::string& content_type);

}  // namespace freeloc::service::http
